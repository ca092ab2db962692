#include "util/spill_file.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <utility>
#include <vector>

#include "util/errors.hpp"

namespace ssrfleet::util {
namespace {

// The mapping grows by doubling from 1 MiB, so a store of B bytes is remapped about log2(B / 1 MiB)
// times (a remap moves no data: the pages stay in the page cache).
constexpr std::size_t kFirstMapping = std::size_t{1} << 20;

std::string errno_text() { return std::strerror(errno); }

int open_unnamed(const std::string& directory) {
  const std::string dir = directory.empty() ? std::string(".") : directory;
  int fd = -1;
#ifdef O_TMPFILE
  fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd >= 0) return fd;
  // Some file systems (overlayfs on older kernels, NFS) refuse O_TMPFILE: a named file, unlinked at once.
#endif
  std::string pattern = dir + "/.ssrfleet-spill-XXXXXX";
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  fd = ::mkostemp(name.data(), O_CLOEXEC);
  if (fd < 0) throw IoError(dir + ": cannot create a spill file (a stream keeps its trucks' tables, data and ids in unnamed files in its state directory): " + errno_text());
  ::unlink(name.data());
  return fd;
}

}  // namespace

SpillFile::SpillFile(const std::string& directory) : directory_(directory), fd_(open_unnamed(directory)) {}

SpillFile::~SpillFile() { release(); }

SpillFile::SpillFile(SpillFile&& other) noexcept
    : directory_(std::move(other.directory_)),
      fd_(std::exchange(other.fd_, -1)),
      map_(std::exchange(other.map_, nullptr)),
      mapped_(std::exchange(other.mapped_, 0)),
      size_(std::exchange(other.size_, 0)) {}

SpillFile& SpillFile::operator=(SpillFile&& other) noexcept {
  if (this != &other) {
    release();
    directory_ = std::move(other.directory_);
    fd_ = std::exchange(other.fd_, -1);
    map_ = std::exchange(other.map_, nullptr);
    mapped_ = std::exchange(other.mapped_, 0);
    size_ = std::exchange(other.size_, 0);
  }
  return *this;
}

void SpillFile::release() noexcept {
  if (map_ != nullptr) ::munmap(map_, mapped_);
  if (fd_ >= 0) ::close(fd_);
  map_ = nullptr;
  mapped_ = 0;
  fd_ = -1;
  size_ = 0;
}

// Writes all n bytes at `offset`, or returns why not.
std::string SpillFile::write_all(std::size_t offset, const void* bytes, std::size_t n) const {
  const auto* p = static_cast<const char*>(bytes);
  std::size_t done = 0;
  while (done < n) {
    const ::ssize_t w = ::pwrite(fd_, p + done, n - done, static_cast<::off_t>(offset + done));
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return w < 0 ? errno_text() : std::string("no progress");
    done += static_cast<std::size_t>(w);
  }
  return {};
}

void SpillFile::append(const void* bytes, std::size_t n) {
  if (n == 0) return;
  if (fd_ < 0) throw IoError("spill file: append to a closed file");
  if (const std::string why = write_all(size_, bytes, n); !why.empty()) {
    // Cut a partial write back, so the file holds exactly size_ bytes (if that fails too, the tail
    // past size_ is never read and the next append overwrites it).
    [[maybe_unused]] const int rc = ::ftruncate(fd_, static_cast<::off_t>(size_));
    throw IoError(directory_ + ": writing a spill file failed: " + why);
  }
  map_at_least(size_ + n);
  size_ += n;
}

void SpillFile::write_at(std::size_t offset, const void* bytes, std::size_t n) {
  if (offset + n > size_) throw std::logic_error("SpillFile::write_at: past the end");
  if (const std::string why = write_all(offset, bytes, n); !why.empty())
    throw IoError(directory_ + ": writing a spill file failed: " + why);
}

void SpillFile::shrink_to(std::size_t bytes) {
  if (bytes >= size_) return;
  if (::ftruncate(fd_, static_cast<::off_t>(bytes)) != 0)
    throw IoError(directory_ + ": cutting a spill file failed: " + errno_text());
  size_ = bytes;
}

void SpillFile::map_at_least(std::size_t bytes) {
  if (bytes <= mapped_) return;
  std::size_t want = mapped_ == 0 ? kFirstMapping : mapped_;
  while (want < bytes) want *= 2;
  void* m = mapped_ == 0 ? ::mmap(nullptr, want, PROT_READ, MAP_SHARED, fd_, 0)
                         : ::mremap(map_, mapped_, want, MREMAP_MAYMOVE);
  if (m == MAP_FAILED) throw IoError(directory_ + ": mapping a spill file failed: " + errno_text());
  map_ = static_cast<std::byte*>(m);
  mapped_ = want;
}

}  // namespace ssrfleet::util
