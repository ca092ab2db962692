// Stream load benchmark: `ssrfleet stream` over a long simulated log with a
// fraction of bad records of every kind salted in at random. It checks that every bad record is in
// rejects.csv with its reason (by line number and verbatim), that every good record was absorbed
// (the posterior's truck count, one history report per truck), and samples the stream's resident
// memory (VmRSS of the process, and its private part RssAnon) and progress as it runs. It passes
// when every record is accounted for and the private memory is flat (see memory_flat below).
//
//   stream_load_benchmark --binary build/ssrfleet [--trucks 100000] [--bad-fraction 0.01]
//                         [--seed 1] [--dir DIR] [--json FILE] [-- extra stream options]
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/history_db.hpp"
#include "io/posterior_json.hpp"
#include "run_info.hpp"

using namespace ssrfleet;
namespace fs = std::filesystem;

namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> f;
  std::stringstream ss(line);
  std::string x;
  while (std::getline(ss, x, ',')) f.push_back(x);
  return f;
}
std::string join(const std::vector<std::string>& f) {
  std::string s;
  for (std::size_t i = 0; i < f.size(); ++i) s += (i ? "," : "") + f[i];
  return s;
}

// One bad record made from a good one (fields: truck_id, speed, mass, if_1..if_M), kind by kind,
// each breaking exactly one rule of the WIM log reader, under a fresh id unless the kind is the id.
std::string bad_record(std::vector<std::string> f, int kind, const std::string& fresh_id,
                       const std::string& earlier_id) {
  f[0] = fresh_id;
  const std::size_t sensor = 3 + static_cast<std::size_t>(kind) % (f.size() - 3);
  switch (kind) {
    case 0: f.pop_back(); break;                 // too few columns
    case 1: f.push_back("1.0"); break;           // too many columns
    case 2: f[1] = "fast"; break;                // speed not a number
    case 3: f[1] = "nan"; break;                 // speed NaN
    case 4: f[1] = "-" + f[1]; break;            // speed negative
    case 5: f[1] = "200"; break;                 // speed impossible
    case 6: f[2] = "heavy"; break;               // mass not a number
    case 7: f[2] = "0"; break;                   // mass zero
    case 8: f[2] = "1e7"; break;                 // mass impossible
    case 9: f[sensor] = "abc"; break;            // IF not a number
    case 10: f[sensor] = "inf"; break;           // IF infinite
    case 11: f[sensor] = "-0.5"; break;          // IF negative
    case 12: f[sensor] = "9.0"; break;           // IF impossible
    case 13: f[sensor] = ""; break;              // IF empty
    case 14: f[0] = ""; break;                   // empty truck_id
    case 15: f[0] = earlier_id; break;           // duplicate truck_id
    default: f[1] += "m/s"; break;               // trailing junk
  }
  return join(f);
}
constexpr int kKinds = 17;

int run(const std::string& command) {
  const int raw = std::system(command.c_str());
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

}  // namespace

int main(int argc, char** argv) {
  std::string binary, dir = "stream-load", json_path;
  long trucks = 100000;
  double bad_fraction = 0.01;
  unsigned seed = 1;
  std::string extra;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << a << " needs a value\n";
        std::exit(64);
      }
      return argv[++i];
    };
    if (a == "--binary") binary = next();
    else if (a == "--trucks") trucks = std::stol(next());
    else if (a == "--bad-fraction") bad_fraction = std::stod(next());
    else if (a == "--seed") seed = static_cast<unsigned>(std::stoul(next()));
    else if (a == "--dir") dir = next();
    else if (a == "--json") json_path = next();
    else if (a == "--") {
      for (++i; i < argc; ++i) extra += std::string(" '") + argv[i] + "'";
    } else {
      std::cerr << "unknown option " << a << "\n";
      return 64;
    }
  }
  if (binary.empty()) {
    std::cerr << "usage: stream_load_benchmark --binary PATH/ssrfleet [--trucks N] [--bad-fraction F] [--dir DIR]\n";
    return 64;
  }
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string good = dir + "/good.csv", salted = dir + "/salted.csv", state = dir + "/state";
  std::cerr << "stream_load: simulating " << trucks << " trucks\n";
  if (run("'" + binary + "' simulate --trucks " + std::to_string(trucks) + " --seed " + std::to_string(seed) +
          " --quiet --out '" + good + "'") != 0) {
    std::cerr << "simulate failed\n";
    return 1;
  }

  // Salt: after each good record, a bad one with probability bad_fraction (kinds in turn).
  std::mt19937_64 rng(seed);
  std::bernoulli_distribution salt(bad_fraction);
  std::ifstream in(good);
  std::ofstream out(salted);
  std::string line, last_id;
  std::size_t line_no = 0;
  long good_rows = 0, bad_rows = 0;
  std::map<std::size_t, std::string> bad_lines;  // line number -> verbatim record
  while (std::getline(in, line)) {
    out << line << "\n";
    ++line_no;
    if (line.empty() || line[0] == '#' || line.rfind("truck_id", 0) == 0) continue;
    ++good_rows;
    const auto fields = split(line);
    if (!last_id.empty() && salt(rng)) {
      const std::string bad = bad_record(fields, static_cast<int>(bad_rows % kKinds), "BAD" + std::to_string(bad_rows),
                                         last_id);
      out << bad << "\n";
      bad_lines[++line_no] = bad;
      ++bad_rows;
    }
    last_id = fields[0];
  }
  out.close();
  std::cerr << "stream_load: " << good_rows << " good and " << bad_rows << " bad records in " << salted << "\n";

  // Stream it, sampling memory and progress.
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string cmd = "exec '" + binary + "' stream --state '" + state + "' --input '" + salted +
                            "' --quiet" + extra + " > '" + dir + "/stream.out' 2> '" + dir + "/stream.err'";
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  nlohmann::json samples = nlohmann::json::array();
  int status = 0;
  for (;;) {
    std::this_thread::sleep_for(std::chrono::seconds(5));
    const std::string process = std::to_string(pid);
    const long rss = bench::resident_kb(process), anon = bench::status_kb(process, "RssAnon"),
               file = bench::status_kb(process, "RssFile"), shmem = bench::status_kb(process, "RssShmem");
    long absorbed = -1;
    try {
      const io::HistoryDb history(state + "/history.sqlite", "base");
      absorbed = static_cast<long>(history.last_seq().value_or(0));
    } catch (const std::exception&) {
    }
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (rss > 0) {
      samples.push_back({{"time_s", t}, {"trucks", absorbed}, {"rss_kb", rss}, {"rss_anon_kb", anon},
                         {"rss_file_kb", file}, {"rss_shmem_kb", shmem}});
      std::cerr << "stream_load: " << std::fixed << std::setprecision(0) << t << " s, " << absorbed << " trucks, "
                << rss / 1024 << " MiB resident, " << anon / 1024 << " MiB private\n";
    }
    if (waitpid(pid, &status, WNOHANG) == pid) break;
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const int exit_status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;

  // Every bad record in rejects.csv, after its reason, under its line number; nothing else there.
  std::ifstream rejects(state + "/rejects.csv");
  std::map<std::size_t, std::string> rejected;
  std::map<std::size_t, std::string> reasons;
  std::string comment;
  while (std::getline(rejects, line)) {
    if (line.rfind("# line ", 0) == 0) {
      comment = line;
      continue;
    }
    if (comment.empty()) continue;  // the file's own header lines
    const std::size_t n = std::stoul(comment.substr(7));
    rejected[n] = line;
    reasons[n] = comment.substr(comment.find(':') + 2);
    comment.clear();
  }
  long missing = 0, unexpected = 0;
  for (const auto& [n, text] : bad_lines) missing += !(rejected.count(n) && rejected[n] == text);
  for (const auto& [n, text] : rejected) unexpected += !bad_lines.count(n);
  long in_posterior = -1, reports = -1;
  try {
    in_posterior = io::read_posterior_file(state).trucks_seen;
    reports = static_cast<long>(io::HistoryDb(state + "/history.sqlite", "base").last_seq().value_or(0));
  } catch (const std::exception& e) {
    std::cerr << "stream_load: reading the state failed: " << e.what() << "\n";
  }
  std::map<std::string, long> by_reason;
  for (const auto& [n, r] : reasons) by_reason[r.substr(0, r.find(':'))]++;

  // Memory: the resident set after 10 % of the trucks against the largest later sample, in all and
  // its private part (RssAnon: what the process itself holds; RssFile is mapped file pages, the
  // spilled tables among them, which the kernel drops under memory pressure and reads back). The
  // private growth per truck is the slope from the sample at 10 % to the last one.
  long rss_early = -1, rss_peak_late = 0, anon_early = -1, anon_peak_late = 0;
  for (const auto& s : samples) {
    const long t = s["trucks"], rss = s["rss_kb"], anon = s["rss_anon_kb"];
    if (rss_early < 0 && t >= trucks / 10) {
      rss_early = rss;
      anon_early = anon;
    }
    if (t >= trucks / 10) {
      rss_peak_late = std::max(rss_peak_late, rss);
      anon_peak_late = std::max(anon_peak_late, anon);
    }
  }
  // The private memory's growth per truck: the mean of the samples taken over the last 10 % of the
  // trucks against the mean of those over 10-20 % (means, since a sample may catch a transient
  // buffer of a few MB), divided by the trucks between the two windows' middles.
  const auto window_mean = [&](long from, long to, double& trucks_mid) {
    double sum = 0.0, t = 0.0;
    long k = 0;
    for (const auto& s : samples) {
      const long n = s["trucks"];
      if (n >= from && n < to) {
        sum += double(s["rss_anon_kb"].get<long>());
        t += double(n);
        ++k;
      }
    }
    trucks_mid = k > 0 ? t / double(k) : 0.0;
    return k > 0 ? sum / double(k) : -1.0;
  };
  double mid_early = 0.0, mid_late = 0.0;
  const double anon_early_mean = window_mean(trucks / 10, trucks / 5, mid_early);
  const double anon_late_mean = window_mean(trucks - trucks / 10, trucks + 1, mid_late);
  const double anon_bytes_per_truck = anon_early_mean > 0.0 && anon_late_mean > 0.0 && mid_late > mid_early
                                          ? 1024.0 * (anon_late_mean - anon_early_mean) / (mid_late - mid_early)
                                          : -1.0;
  // Flat: at most 64 bytes a truck (under 1.4 % of the 4.7 kB a truck that the tables alone cost
  // when they were kept in memory).
  const bool memory_flat = anon_bytes_per_truck >= -64.0 && anon_bytes_per_truck <= 64.0;
  const bool ok = exit_status == 0 && missing == 0 && unexpected == 0 && in_posterior == good_rows &&
                  reports == good_rows && memory_flat;
  nlohmann::json report = {
      {"trucks_good", good_rows}, {"records_bad", bad_rows}, {"bad_fraction", bad_fraction},
      {"exit_status", exit_status}, {"wall_s", wall}, {"trucks_per_s", good_rows / wall},
      {"bad_missing_from_rejects", missing}, {"rejects_not_salted", unexpected},
      {"trucks_in_posterior", in_posterior}, {"history_reports", reports}, {"rejects_by_field", by_reason},
      {"rss_kb_at_10pct", rss_early}, {"rss_kb_peak_after_10pct", rss_peak_late},
      {"rss_growth_after_10pct", rss_early > 0 ? double(rss_peak_late) / double(rss_early) : 0.0},
      {"rss_anon_kb_at_10pct", anon_early}, {"rss_anon_kb_peak_after_10pct", anon_peak_late},
      {"rss_anon_growth_after_10pct", anon_early > 0 ? double(anon_peak_late) / double(anon_early) : 0.0},
      {"rss_anon_bytes_per_truck", anon_bytes_per_truck}, {"memory_flat", memory_flat}, {"load_average_1min", bench::load_average_1min()},
      {"samples", samples}, {"pass", ok}};
  std::cout << report.dump(2) << "\n";
  if (!json_path.empty()) std::ofstream(json_path) << report.dump(2) << "\n";
  return ok ? 0 : 1;
}
