#include "serve/stream_status.hpp"

#include <sys/stat.h>
#include <sys/sysmacros.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

namespace ssrfleet::serve {

std::optional<long> flock_holder(std::string_view proc_locks, unsigned dev_major, unsigned dev_minor,
                                 unsigned long inode) {
  // A line: "1: FLOCK  ADVISORY  WRITE 350 08:01:123456 0 EOF", the device as hex major:minor.
  std::size_t start = 0;
  while (start < proc_locks.size()) {
    std::size_t end = proc_locks.find('\n', start);
    if (end == std::string_view::npos) end = proc_locks.size();
    std::istringstream line{std::string(proc_locks.substr(start, end - start))};
    start = end + 1;
    std::vector<std::string> fields;
    for (std::string f; line >> f;) fields.push_back(f);
    if (fields.size() < 6 || fields[1] != "FLOCK") continue;  // also skips "->" waiter lines
    const std::string& id = fields[5];
    const std::size_t c1 = id.find(':'), c2 = id.rfind(':');
    if (c1 == std::string::npos || c2 == c1) continue;
    char* e1 = nullptr;
    char* e2 = nullptr;
    char* e3 = nullptr;
    const std::string major_text = id.substr(0, c1), minor_text = id.substr(c1 + 1, c2 - c1 - 1),
                      inode_text = id.substr(c2 + 1);
    const unsigned long major = std::strtoul(major_text.c_str(), &e1, 16);
    const unsigned long minor = std::strtoul(minor_text.c_str(), &e2, 16);
    const unsigned long ino = std::strtoul(inode_text.c_str(), &e3, 10);
    if (*e1 != '\0' || *e2 != '\0' || *e3 != '\0') continue;
    if (major == dev_major && minor == dev_minor && ino == inode) {
      char* e4 = nullptr;
      const long pid = std::strtol(fields[4].c_str(), &e4, 10);
      if (*e4 == '\0' && pid > 0) return pid;
    }
  }
  return std::nullopt;
}

LockState lock_state(const std::string& state_dir) {
  LockState s;
  struct stat st {};
  if (::stat((state_dir + "/lock").c_str(), &st) != 0) {
    s.lock_file = false;
    return s;
  }
  s.lock_file = true;
  std::ifstream in("/proc/locks");
  if (!in) {
    s.known = false;
    return s;
  }
  std::ostringstream text;
  text << in.rdbuf();
  s.pid = flock_holder(text.str(), major(st.st_dev), minor(st.st_dev), static_cast<unsigned long>(st.st_ino));
  return s;
}

std::string stream_status(const LockState& lock, bool has_checkpoint, double checkpoint_age_s,
                          double idle_after_s) {
  if (!lock.known) {
    if (!has_checkpoint) return "waiting";
    return checkpoint_age_s > idle_after_s ? "stopped" : "running";
  }
  if (!lock.pid) return has_checkpoint || lock.lock_file ? "stopped" : "waiting";
  if (!has_checkpoint) return "waiting";
  return checkpoint_age_s > idle_after_s ? "idle" : "running";
}

}  // namespace ssrfleet::serve
