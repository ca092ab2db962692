// One writer per stream state directory: an flock(2) on DIR/lock, held for the life of
// the stream. The kernel drops it when its holder exits, however it exits (kill -9 included), so a
// resume after a crash needs no clean-up, while a second stream started on a live state stops at
// once (BusyError, exit 75) before it reads or writes anything there.
#pragma once

#include <string>

namespace ssrfleet::stream {

class StateLock {
 public:
  // Takes the lock on DIR/lock (creating the file), or throws BusyError naming the directory and
  // the holder's process id; IoError if the lock file cannot be opened.
  explicit StateLock(const std::string& state_dir);
  ~StateLock();
  StateLock(const StateLock&) = delete;
  StateLock& operator=(const StateLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace ssrfleet::stream
