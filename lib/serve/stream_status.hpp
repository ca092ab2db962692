// Whether a stream is running on a state directory, found without opening anything in it: the
// running stream holds an flock(2) on DIR/lock (stream/state_lock.hpp), and Linux lists every
// flock in /proc/locks by device and inode. So `serve` stat(2)s DIR/lock and looks for its inode
// there: the holder's process id when one holds it, none when the stream has exited (the kernel
// drops the lock however it exits, kill -9 included). Taking or even opening the lock file could
// disturb the stream; reading /proc/locks cannot.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace ssrfleet::serve {

// The pid holding an FLOCK on the file with this device and inode in the text of /proc/locks;
// none if no line matches (waiters, "->" lines, are not holders).
std::optional<long> flock_holder(std::string_view proc_locks, unsigned dev_major, unsigned dev_minor,
                                 unsigned long inode);

struct LockState {
  bool lock_file = false;   // DIR/lock exists (a stream has run on this state)
  std::optional<long> pid;  // the running stream's process id
  bool known = true;        // false where /proc/locks cannot be read (then pid is none)
};

LockState lock_state(const std::string& state_dir);

// The page's plain words for a state: "running", "idle" (running, but no checkpoint for
// idle_after_s: a followed file that stopped growing), "stopped" (no process holds the lock), or
// "waiting" (no checkpoint yet). Without /proc/locks, a checkpoint older than idle_after_s counts as
// stopped.
std::string stream_status(const LockState& lock, bool has_checkpoint, double checkpoint_age_s,
                          double idle_after_s);

}  // namespace ssrfleet::serve
