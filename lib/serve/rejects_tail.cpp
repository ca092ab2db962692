#include "serve/rejects_tail.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <charconv>

namespace ssrfleet::serve {

namespace {

constexpr std::string_view kMarker = "# line ";
constexpr std::size_t kTailBytes = 64 * 1024;

// Reads [offset, offset + n) of the file; fewer bytes if it is shorter.
std::string read_range(int fd, std::uint64_t offset, std::size_t n) {
  std::string out(n, '\0');
  std::size_t got = 0;
  while (got < n) {
    const ssize_t r = ::pread(fd, out.data() + got, n - got, static_cast<off_t>(offset + got));
    if (r <= 0) break;
    got += static_cast<std::size_t>(r);
  }
  out.resize(got);
  return out;
}

}  // namespace

std::vector<RejectedRecord> parse_rejects(std::string_view text, std::size_t limit) {
  std::vector<RejectedRecord> all;
  std::size_t start = 0;
  bool want_record = false;
  while (start < text.size()) {
    const std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) break;  // a line still being written
    const std::string_view line = text.substr(start, end - start);
    start = end + 1;
    if (line.substr(0, kMarker.size()) == kMarker) {
      RejectedRecord r;
      const std::string_view rest = line.substr(kMarker.size());
      const std::size_t colon = rest.find(": ");
      if (colon == std::string_view::npos) continue;
      std::from_chars(rest.data(), rest.data() + colon, r.line);
      const std::string_view why = rest.substr(colon + 2);
      const std::size_t colon2 = why.find(": ");
      if (colon2 == std::string_view::npos) {
        r.reason = std::string(why);
      } else {
        r.field = std::string(why.substr(0, colon2));
        r.reason = std::string(why.substr(colon2 + 2));
      }
      all.push_back(std::move(r));
      want_record = true;
    } else if (want_record && !all.empty()) {
      all.back().record = std::string(line.substr(0, 512));
      want_record = false;
    }
  }
  if (all.size() > limit) all.erase(all.begin(), all.end() - static_cast<std::ptrdiff_t>(limit));
  return all;
}

void RejectsTail::refresh(std::size_t keep) {
  const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const std::lock_guard<std::mutex> lock(mutex_);
    scanned_bytes_ = 0;
    total_ = 0;
    last_.clear();
    return;
  }
  struct stat st {};
  ::fstat(fd, &st);
  const auto size = static_cast<std::uint64_t>(st.st_size);
  std::uint64_t scanned = 0;
  std::int64_t total = 0;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (size == scanned_bytes_) {
      ::close(fd);
      return;
    }
    if (size > scanned_bytes_) {  // appended: count only the new whole lines
      scanned = scanned_bytes_;
      total = total_;
    }  // else cut back by a resume: count again from the start
  }
  // Count markers in chunks, each ending at a whole line.
  while (scanned < size) {
    const std::string chunk =
        read_range(fd, scanned, static_cast<std::size_t>(std::min<std::uint64_t>(size - scanned, 1 << 20)));
    const std::size_t last_newline = chunk.rfind('\n');
    if (last_newline == std::string::npos) break;
    const std::string_view whole(chunk.data(), last_newline + 1);
    std::size_t at = 0;
    while (at < whole.size()) {
      if (whole.substr(at, kMarker.size()) == kMarker) ++total;
      const std::size_t nl = whole.find('\n', at);
      at = nl + 1;
    }
    scanned += last_newline + 1;
  }
  const std::uint64_t tail_start = scanned > kTailBytes ? scanned - kTailBytes : 0;
  std::string tail = read_range(fd, tail_start, static_cast<std::size_t>(scanned - tail_start));
  ::close(fd);
  if (tail_start > 0) {  // start at a whole line
    const std::size_t nl = tail.find('\n');
    tail.erase(0, nl == std::string::npos ? tail.size() : nl + 1);
  }
  std::vector<RejectedRecord> last = parse_rejects(tail, keep);
  const std::lock_guard<std::mutex> lock(mutex_);
  scanned_bytes_ = scanned;
  total_ = total;
  last_ = std::move(last);
}

std::int64_t RejectsTail::total() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return total_;
}

std::vector<RejectedRecord> RejectsTail::last(std::size_t n) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  const std::size_t k = std::min(n, last_.size());
  return {last_.end() - static_cast<std::ptrdiff_t>(k), last_.end()};
}

}  // namespace ssrfleet::serve
