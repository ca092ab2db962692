// Writes a file so that readers never see half of it: the content goes to a temporary file in the
// same directory, is flushed, and is renamed over the target. A failure leaves no output at all.
#pragma once

#include <functional>
#include <ostream>
#include <string>

namespace ssrfleet::io {

// Calls write(stream) on a temporary sibling of `path`, then renames it to `path`. Throws
// IoError naming the path if anything fails; the temporary is removed on every failure path,
// including an exception thrown by `write`.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write);

// Appends bytes to `path` (created if missing) and fsyncs it before returning, so a checkpoint
// written afterwards may count on them. IoError naming the path on any failure; a failed append
// may leave a partial tail, which the caller's checkpoint (naming the good length) cuts off.
void append_file_synced(const std::string& path, const std::string& bytes);

}  // namespace ssrfleet::io
