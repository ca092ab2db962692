// The quarantine as the page shows it: how many records rejects.csv holds and the last few, each
// with its input line, field and reason. The stream appends "# line N: FIELD: REASON" and then the
// record verbatim (docs/streaming.md); a resume may cut the file back. Only new bytes are read on
// each refresh (the count is kept), and the last records come from the file's final 64 KiB, so a
// long quarantine costs neither time nor memory.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace ssrfleet::serve {

struct RejectedRecord {
  std::int64_t line = 0;  // the record's line in the stream's input
  std::string field, reason;
  std::string record;  // the record as it came (cut to 512 bytes)
};

// Parses whole lines of rejects.csv; the last `limit` records, oldest first.
std::vector<RejectedRecord> parse_rejects(std::string_view text, std::size_t limit);

class RejectsTail {
 public:
  explicit RejectsTail(std::string path) : path_(std::move(path)) {}
  // Re-reads what changed: the count and the last `keep` records.
  void refresh(std::size_t keep = 50);
  std::int64_t total() const;
  std::vector<RejectedRecord> last(std::size_t n) const;

 private:
  std::string path_;
  mutable std::mutex mutex_;
  std::uint64_t scanned_bytes_ = 0;  // the count covers the file up to here (a whole line)
  std::int64_t total_ = 0;
  std::vector<RejectedRecord> last_;
};

}  // namespace ssrfleet::serve
