#include "stream/state_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

#include "util/errors.hpp"

namespace ssrfleet::stream {

StateLock::StateLock(const std::string& state_dir) {
  const std::string path = (std::filesystem::path(state_dir) / "lock").string();
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw IoError("stream: cannot open the lock file '" + path + "': " + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int why = errno;
    // The holder wrote its process id when it took the lock: name it in the message.
    char buffer[32] = {};
    const ssize_t n = ::pread(fd_, buffer, sizeof buffer - 1, 0);
    std::string holder = n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : std::string();
    while (!holder.empty() && (holder.back() == '\n' || holder.back() == ' ')) holder.pop_back();
    ::close(fd_);
    fd_ = -1;
    if (why == EWOULDBLOCK) {
      throw BusyError("the state directory '" + state_dir + "' is in use by another stream" +
                      (holder.empty() ? std::string() : " (process " + holder + ")") +
                      "; one state takes one writer: stop that stream first, or use another --state");
    }
    throw IoError("stream: cannot lock '" + path + "': " + std::strerror(why));
  }
  // Ours now: record who holds it (for the message above; the lock itself is the kernel's).
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd_, 0) == 0) {
    [[maybe_unused]] const ssize_t written = ::pwrite(fd_, pid.data(), pid.size(), 0);
  }
}

StateLock::~StateLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the descriptor releases the lock
}

}  // namespace ssrfleet::stream
