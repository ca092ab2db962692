// A fault-injection hook for tests of the state directory's behaviour on a full disk: every write
// that the stream's state depends on (an atomic file, an append, a history transaction) first asks
// check_write_fault(), which throws the IoError a full disk would give once the armed countdown
// reaches zero. Off unless a test arms it; one countdown for the whole process.
#pragma once

#include <string>

namespace ssrfleet::io {

// The `operations`-th write from now (1 = the next) fails; 0 disarms.
void arm_write_fault(int operations);
void disarm_write_fault();
// Writes seen since the last arm (a test counts them to fail each one in turn).
int write_operations_seen();

// Called by each writer before it commits anything to `path`: counts the write and, when the
// countdown runs out, throws IoError("writing '<path>' failed: No space left on device (injected)").
void check_write_fault(const std::string& path);

}  // namespace ssrfleet::io
