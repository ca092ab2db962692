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

}  // namespace ssrfleet::io
