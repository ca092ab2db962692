#include "io/atomic_file.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "io/write_faults.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  try {
    {
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      if (!out) throw IoError("cannot open '" + tmp + "' for writing: " + std::strerror(errno));
      write(out);
      out.flush();
      if (!out) throw IoError("writing '" + path + "' failed (disk full?)");
    }
    check_write_fault(path);  // a test's full disk strikes here: the temporary exists, the target is untouched
    // fsync so a crash right after the rename cannot leave an empty file behind the new name; a
    // file system that allocates late reports a full disk here, not at the write.
    FILE* f = std::fopen(tmp.c_str(), "rb");
    if (f == nullptr) throw IoError("cannot reopen '" + tmp + "' to sync it: " + std::strerror(errno));
    const bool synced = ::fsync(fileno(f)) == 0;
    const int err = errno;
    std::fclose(f);
    if (!synced) throw IoError("writing '" + path + "' failed at sync: " + std::strerror(err));
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
      throw IoError("cannot rename '" + tmp + "' to '" + path + "': " + std::strerror(errno));
    }
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
}

void append_file_synced(const std::string& path, const std::string& bytes) {
  FILE* f = std::fopen(path.c_str(), "ab");
  if (f == nullptr) throw IoError("cannot open '" + path + "' for appending: " + std::strerror(errno));
  try {
    check_write_fault(path);
  } catch (const IoError&) {
    // A test's full disk: half the bytes land, as a real one may leave them; the caller's
    // checkpoint still names the good length.
    std::fwrite(bytes.data(), 1, bytes.size() / 2, f);
    std::fclose(f);
    throw;
  }
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size() && std::fflush(f) == 0 &&
                       ::fsync(fileno(f)) == 0;
  const int err = errno;
  const bool closed = std::fclose(f) == 0;
  if (!written || !closed) throw IoError("appending to '" + path + "' failed (disk full?): " + std::strerror(err));
}

}  // namespace ssrfleet::io
