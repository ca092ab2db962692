// What a benchmark records about the run beside its numbers: the time, the machine's load (the
// 2-core machines are shared, so a ratio needs its load beside it) and the commit.
#pragma once

#include <cstdio>
#include <ctime>
#include <fstream>
#include <string>

namespace ssrfleet::bench {

// A kB field of a process's /proc/PID/status ("self" or a pid), e.g. "VmRSS" (the resident set),
// "RssAnon" (its private part), "RssFile" (mapped file pages: page cache the kernel may drop),
// "RssShmem"; -1 if unreadable.
inline long status_kb(const std::string& process, const std::string& field) {
  std::ifstream status("/proc/" + process + "/status");
  std::string key;
  while (status >> key) {
    if (key == field + ":") {
      long kb = 0;
      status >> kb;
      return kb;
    }
    std::getline(status, key);
  }
  return -1;
}

// The resident set (VmRSS, kB) of a process ("self" or a pid) from /proc; -1 if unreadable.
inline long resident_kb(const std::string& process = "self") { return status_kb(process, "VmRSS"); }

// The 1-minute load average from /proc/loadavg, or -1 when unreadable.

inline double load_average_1min() {
  std::ifstream f("/proc/loadavg");
  double l = -1.0;
  f >> l;
  return l;
}

// What a shell command prints on stdout, without the trailing newline ("" if it cannot run).
inline std::string run_command(const std::string& cmd) {
  std::string out;
  if (FILE* p = popen(cmd.c_str(), "r")) {
    char buf[256];
    while (fgets(buf, sizeof buf, p)) out += buf;
    pclose(p);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

// Now, UTC, ISO 8601.
inline std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

}  // namespace ssrfleet::bench
