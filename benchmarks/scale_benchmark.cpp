// Scale benchmark (docs/inference.md, how a flat per-truck cost is judged):
// streams a simulated log truck by truck into the marginal core (fleet::MarginalSmc: 1,024
// particles, 2 threads, seed 1; Table 1 fleet, road AS1, σ_IF = 0.02) and records
//   - the wall time of every absorb() (a float per truck), and from it the mean per truck over
//     (n/2, n] for n = 2,000, 4,000, ... (the design's rule, a move phase amortised over the trucks
//     it serves), over trucks 1,001-2,000 and over the last 1,000 (the targets' windows), their
//     ratios, and the sustained trucks/s;
//   - the peak resident set (getrusage ru_maxrss and VmHWM) at n = 1,000, 10,000, 100,000 and the
//     end, the tables' bytes, integrator passes per truck, move phases and table rebuilds;
//   - the posterior mean and sd of the 7 hyperparameters at n = 1,000, 10,000 and the end.
// The log is generated in chunks of --chunk trucks (seed 1 + chunk index for both the fleet draw and
// the noise), so the generator's memory stays small; simulation is outside the absorb timings.
// Progress goes to stderr every 1,000 trucks. SIGINT/SIGTERM stop the stream after the current
// truck and write the results so far (marked "complete": false); --checkpoints also writes them
// at every power of ten and every 10,000 trucks, so a killed run leaves its numbers behind.
//
//   scale_benchmark [--trucks 100000] [--particles 1024] [--threads 2] [--seed 1] [--chunk 1000]
//                   [--json FILE] [--markdown FILE] [--curve FILE] [--per-truck FILE]
//                   [--commit HASH] [--checkpoints]
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/fleet_distribution.hpp"
#include "model/fleet_model.hpp"
#include "fleet/marginal_smc.hpp"
#include "fleet/simulator.hpp"
#include "site/road_source.hpp"
#include "run_info.hpp"

using namespace ssrfleet;
using bench::load_average_1min;
using bench::run_command;
using bench::utc_now;

namespace {

volatile std::sig_atomic_t g_stop = 0;
extern "C" void on_signal(int sig) { g_stop = sig; }

struct MemoryKb {
  long maxrss = -1, hwm = -1, rss = -1;
};

MemoryKb memory_kb() {
  MemoryKb m;
  rusage u{};
  if (getrusage(RUSAGE_SELF, &u) == 0) m.maxrss = u.ru_maxrss;  // kB on Linux
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmHWM:") status >> m.hwm;
    else if (key == "VmRSS:") status >> m.rss;
    std::getline(status, key);
  }
  return m;
}

double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

nlohmann::json memory_json(const MemoryKb& m) {
  return {{"ru_maxrss_kb", m.maxrss}, {"vm_hwm_kb", m.hwm}, {"vm_rss_kb", m.rss},
          {"peak_mib", static_cast<double>(std::max(m.maxrss, m.hwm)) / 1024.0}};
}

nlohmann::json posterior_json(const fleet::MarginalSmc& smc) {
  const fleet::PosteriorCloud c = smc.cloud();
  nlohmann::json j = nlohmann::json::object();
  for (int h = 0; h < fleet::kHyperCount; ++h) {
    const Eigen::ArrayXd x = c.theta.row(h).transpose().array();
    const double mean = (x * c.weights).sum();
    const double var = (c.weights * (x - mean).square()).sum();
    j[std::string(fleet::kHyperNames[h])] = {{"mean", mean}, {"sd", std::sqrt(var)}};
  }
  j["weight_ess"] = c.weight_ess;
  j["log_evidence"] = c.log_evidence;
  return j;
}

// Mean ms per truck over trucks (a, b] (1-based truck numbers), or NaN.
double window_mean_ms(const std::vector<float>& ms, long a, long b) {
  a = std::max(0L, a);
  b = std::min<long>(b, static_cast<long>(ms.size()));
  if (b <= a) return std::nan("");
  double s = 0.0;
  for (long i = a; i < b; ++i) s += ms[i];
  return s / static_cast<double>(b - a);
}

struct Snapshot {  // what is recorded at a milestone n
  long n = 0;
  double elapsed_absorb_s = 0.0, elapsed_wall_s = 0.0;
  MemoryKb memory;
  std::size_t table_bytes = 0, table_nodes = 0;
  long long passes = 0;
  int move_phases = 0, rebuilds = 0;
  nlohmann::json posterior;  // only at 1k, 10k and the end
};

struct Rebuild {
  long n;
  float ms;
  std::string reason;
};

struct Run {
  // settings
  long trucks_requested = 0, particles = 0, threads = 0, chunk = 0;
  std::uint64_t seed = 1;
  std::string commit, dirty, started, road = "AS1";
  double load_start = 0.0;
  long nproc = 0;
  // per truck
  std::vector<float> ms;
  std::vector<std::uint8_t> moves;  // resampled steps in the truck's stage
  // totals
  double absorb_s = 0.0, simulate_s = 0.0, wall_s = 0.0, cpu_s = 0.0;
  int move_phases = 0, rebuilds = 0;
  long long mh_sweeps = 0;
  std::vector<Rebuild> rebuild_log;
  std::vector<Snapshot> snapshots;
  // per 1,000-truck block: wall of absorbs and process CPU (contention check)
  std::vector<double> block_wall_s, block_cpu_s;
};

std::vector<long> curve_points(long n_done) {
  std::vector<long> pts;
  for (long n = 2; n < 2000 && n <= n_done; n *= 2) pts.push_back(n);
  for (long n = 2000; n <= n_done; n += 2000) pts.push_back(n);
  if (n_done >= 2 && (pts.empty() || pts.back() != n_done)) pts.push_back(n_done);
  std::sort(pts.begin(), pts.end());
  pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
  return pts;
}

std::string fmt(double v, int prec = 3) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream s;
  s << std::fixed << std::setprecision(prec) << v;
  return s.str();
}

void write_results(const Run& run, const fleet::MarginalSmc& smc, bool complete, const std::string& json_path,
                   const std::string& md_path, const std::string& curve_path, const std::string& per_truck_path,
                   const std::string& status) {
  const long n = static_cast<long>(run.ms.size());
  nlohmann::json j;
  j["benchmark"] = "scale";
  j["status"] = status;
  j["complete"] = complete;
  j["started_utc"] = run.started;
  j["written_utc"] = utc_now();
  j["commit"] = run.commit;
  j["working_tree_lib_changes"] = run.dirty;
  j["nproc"] = run.nproc;
  j["load_average_1min"] = {{"start", run.load_start}, {"end", load_average_1min()}};
  j["settings"] = {{"trucks_requested", run.trucks_requested}, {"particles", run.particles},
                   {"threads", run.threads},   {"seed", run.seed},
                   {"fleet", "Table 1 (FleetDistribution defaults)"}, {"road", run.road},
                   {"sigma_if", 0.02},       {"chunk", run.chunk},
                   {"chunk_seeds", "1 + chunk index (fleet draw and noise)"}};
  j["trucks"] = n;
  j["absorb_total_s"] = run.absorb_s;
  j["simulate_total_s"] = run.simulate_s;
  j["wall_total_s"] = run.wall_s;
  j["process_cpu_s"] = run.cpu_s;
  j["cores_busy_mean"] = run.wall_s > 0 ? run.cpu_s / run.wall_s : 0.0;
  j["sustained_trucks_per_s"] = run.absorb_s > 0 ? static_cast<double>(n) / run.absorb_s : 0.0;
  j["target_trucks_per_s"] = 30.0;

  // The targets' windows and the design's.
  const double w_early = window_mean_ms(run.ms, 1000, 2000);
  const double w_last = n >= 2000 ? window_mean_ms(run.ms, n - 1000, n) : std::nan("");
  const double w_half_n = window_mean_ms(run.ms, n / 2, n);
  const double w_half_2000 = window_mean_ms(run.ms, 1000, 2000);
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  j["windows_ms_per_truck"] = {{"trucks_1001_2000", num(w_early)},
                               {"last_1000", num(w_last)},
                               {"last_1000_range", {std::max(0L, n - 999), n}},
                               {"half_window_at_n", num(w_half_n)}};
  j["ratio_last1000_over_1001_2000"] = num(w_last / w_early);
  j["ratio_half_window_N_over_2000"] = num(w_half_n / w_half_2000);
  j["target_ratio"] = 2.0;
  nlohmann::json doubling = nlohmann::json::array();
  for (long m = 2000; m <= n; m *= 2)
    doubling.push_back({{"n", m}, {"mean_ms_per_truck", window_mean_ms(run.ms, m / 2, m)}});
  if (n >= 2000 && (doubling.empty() || doubling.back()["n"] != n))
    doubling.push_back({{"n", n}, {"mean_ms_per_truck", window_mean_ms(run.ms, n / 2, n)}});
  j["half_windows_doubling"] = doubling;
  nlohmann::json every = nlohmann::json::array();
  for (long m = 2000; m <= n; m += 2000)
    every.push_back({{"n", m}, {"mean_ms_per_truck", window_mean_ms(run.ms, m / 2, m)}});
  j["half_windows_every_2000"] = every;
  nlohmann::json blocks = nlohmann::json::array();
  for (std::size_t b = 0; b < run.block_wall_s.size(); ++b) {
    const long lo = static_cast<long>(b) * 1000, hi = std::min<long>(lo + 1000, n);
    int mv = 0;
    for (long i = lo; i < hi; ++i) mv += run.moves[i];
    blocks.push_back({{"trucks", {lo + 1, hi}},
                      {"mean_ms", window_mean_ms(run.ms, lo, hi)},
                      {"max_ms", *std::max_element(run.ms.begin() + lo, run.ms.begin() + hi)},
                      {"move_phases", mv},
                      {"cores_busy", run.block_wall_s[b] > 0 ? run.block_cpu_s[b] / run.block_wall_s[b] : 0.0}});
  }
  j["blocks_of_1000"] = blocks;

  j["move_phases"] = run.move_phases;
  j["mh_sweeps"] = run.mh_sweeps;
  j["rebuilds"] = run.rebuilds;
  nlohmann::json rb = nlohmann::json::array();
  for (const auto& r : run.rebuild_log) rb.push_back({{"n", r.n}, {"absorb_ms", r.ms}, {"reason", r.reason}});
  j["rebuild_log"] = rb;
  j["table_bytes"] = smc.target().tables().bytes();
  j["table_nodes"] = smc.target().tables().nodes();
  j["integrator_passes"] = smc.target().integrator_passes();
  j["integrator_passes_per_truck"] = n > 0 ? static_cast<double>(smc.target().integrator_passes()) / n : 0.0;
  j["memory_now"] = memory_json(memory_kb());
  j["target_peak_rss_mib_at_100k"] = 1024;
  nlohmann::json snaps = nlohmann::json::array();
  for (const auto& s : run.snapshots) {
    nlohmann::json e = {{"n", s.n},
                        {"absorb_s", s.elapsed_absorb_s},
                        {"wall_s", s.elapsed_wall_s},
                        {"memory", memory_json(s.memory)},
                        {"table_bytes", s.table_bytes},
                        {"table_nodes", s.table_nodes},
                        {"table_nodes_per_truck", static_cast<double>(s.table_nodes) / s.n},
                        {"integrator_passes", s.passes},
                        {"integrator_passes_per_truck", static_cast<double>(s.passes) / s.n},
                        {"move_phases", s.move_phases},
                        {"rebuilds", s.rebuilds}};
    if (!s.posterior.is_null()) e["posterior"] = s.posterior;
    snaps.push_back(e);
  }
  j["snapshots"] = snaps;

  if (!json_path.empty()) {
    std::ofstream f(json_path);
    f << j.dump(2) << "\n";
  }
  if (!curve_path.empty()) {
    std::ofstream f(curve_path);
    f << "window_end_n,mean_ms_per_truck\n";
    for (long m : curve_points(n)) f << m << "," << std::setprecision(6) << window_mean_ms(run.ms, m / 2, m) << "\n";
  }
  if (!per_truck_path.empty()) {
    std::ofstream f(per_truck_path);
    f << "n,absorb_ms,move_phases\n";
    for (long i = 0; i < n; ++i) f << i + 1 << "," << run.ms[i] << "," << int(run.moves[i]) << "\n";
  }
  if (!md_path.empty()) {
    std::ofstream f(md_path);
    f << "# Scale benchmark: marginal core, " << n << " trucks" << (complete ? "" : " (PARTIAL: " + status + ")")
      << "\n\n";
    f << "Table 1 fleet, road AS1, sigma_IF 0.02; MarginalSmc, " << run.particles << " particles, " << run.threads
      << " threads, seed " << run.seed << ". Commit " << run.commit
      << (run.dirty.empty() ? "" : " + uncommitted lib changes (" + run.dirty + ")") << ", nproc " << run.nproc
      << ", 1-min load " << fmt(run.load_start, 2) << " at start, " << fmt(load_average_1min(), 2)
      << " at end. Started " << run.started << ", written " << utc_now() << ".\n\n";
    f << "| quantity | value | target |\n|---|---|---|\n";
    f << "| trucks absorbed | " << n << " | 100,000 |\n";
    f << "| mean ms/truck, trucks 1,001-2,000 | " << fmt(w_early) << " | |\n";
    f << "| mean ms/truck, last 1,000 (" << std::max(0L, n - 999) << "-" << n << ") | " << fmt(w_last) << " | |\n";
    f << "| ratio last 1,000 / 1,001-2,000 | " << fmt(w_last / w_early) << " | <= 2 |\n";
    f << "| ratio (n/2, n] at n=" << n << " / at n=2,000 | " << fmt(w_half_n / w_half_2000)
      << " | <= 2 |\n";
    f << "| sustained trucks/s (n / sum of absorb times) | "
      << fmt(run.absorb_s > 0 ? n / run.absorb_s : 0.0, 1) << " | >= 30 |\n";
    f << "| absorb total / simulate total / wall | " << fmt(run.absorb_s, 1) << " s / " << fmt(run.simulate_s, 1)
      << " s / " << fmt(run.wall_s, 1) << " s | |\n";
    f << "| mean cores busy | " << fmt(run.wall_s > 0 ? run.cpu_s / run.wall_s : 0.0, 2) << " | |\n";
    f << "| move phases (resampled steps) / MH sweeps | " << run.move_phases << " / " << run.mh_sweeps << " | |\n";
    f << "| table rebuilds | " << run.rebuilds << " | |\n";
    f << "| tables bytes | " << smc.target().tables().bytes() << " ("
      << fmt(smc.target().tables().bytes() / 1048576.0, 1) << " MiB) | |\n";
    f << "| integrator passes per truck | "
      << fmt(n > 0 ? static_cast<double>(smc.target().integrator_passes()) / n : 0.0, 0) << " | |\n\n";
    f << "## Milestones\n\n| n | absorb s | peak RSS MiB (ru_maxrss / VmHWM) | tables MiB | nodes/truck | "
         "passes/truck | move phases | rebuilds |\n|---|---|---|---|---|---|---|---|\n";
    for (const auto& s : run.snapshots)
      f << "| " << s.n << " | " << fmt(s.elapsed_absorb_s, 1) << " | " << fmt(s.memory.maxrss / 1024.0, 1) << " / "
        << fmt(s.memory.hwm / 1024.0, 1) << " | " << fmt(s.table_bytes / 1048576.0, 2) << " | "
        << fmt(static_cast<double>(s.table_nodes) / s.n, 1) << " | " << fmt(static_cast<double>(s.passes) / s.n, 0)
        << " | " << s.move_phases << " | " << s.rebuilds << " |\n";
    f << "\nTarget: peak RSS <= 1,024 MiB at n = 100,000.\n\n";
    f << "## Mean wall ms per truck over (n/2, n]\n\n| n | ms/truck |\n|---|---|\n";
    for (const auto& d : doubling) f << "| " << d["n"].get<long>() << " | " << fmt(d["mean_ms_per_truck"].get<double>()) << " |\n";
    f << "\n## Rebuilds\n\n| n | absorb ms | reason |\n|---|---|---|\n";
    for (const auto& r : run.rebuild_log) f << "| " << r.n << " | " << fmt(r.ms, 1) << " | " << r.reason << " |\n";
    f << "\n## Posterior (weighted mean ± sd)\n\n| hyper |";
    std::vector<const Snapshot*> post;
    for (const auto& s : run.snapshots)
      if (!s.posterior.is_null()) post.push_back(&s);
    for (const auto* s : post) f << " n=" << s->n << " |";
    f << "\n|---|";
    for (std::size_t i = 0; i < post.size(); ++i) f << "---|";
    f << "\n";
    for (int h = 0; h < fleet::kHyperCount; ++h) {
      const std::string name(fleet::kHyperNames[h]);
      f << "| " << name << " |";
      for (const auto* s : post) {
        std::ostringstream c;
        c << std::setprecision(5) << s->posterior[name]["mean"].get<double>() << " ± " << std::setprecision(3)
          << s->posterior[name]["sd"].get<double>();
        f << " " << c.str() << " |";
      }
      f << "\n";
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  Run run;
  run.trucks_requested = 100000;
  run.particles = 1024;
  run.threads = 2;
  run.chunk = 1000;
  std::string json_path, md_path, curve_path, per_truck_path;
  bool checkpoints = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--trucks") run.trucks_requested = std::stol(next());
    else if (a == "--particles") run.particles = std::stol(next());
    else if (a == "--threads") run.threads = std::stol(next());
    else if (a == "--seed") run.seed = std::stoull(next());
    else if (a == "--chunk") run.chunk = std::stol(next());
    else if (a == "--json") json_path = next();
    else if (a == "--markdown") md_path = next();
    else if (a == "--curve") curve_path = next();
    else if (a == "--per-truck") per_truck_path = next();
    else if (a == "--commit") run.commit = next();
    else if (a == "--checkpoints") checkpoints = true;
    else {
      std::cerr << "usage: scale_benchmark [--trucks N] [--particles P] [--threads T] [--seed S] [--chunk C]\n"
                   "                       [--json FILE] [--markdown FILE] [--curve FILE] [--per-truck FILE]\n"
                   "                       [--commit HASH] [--checkpoints]\n";
      return a == "--help" ? 0 : 64;
    }
  }
  if (run.trucks_requested < 1 || run.chunk < 1) {
    std::cerr << "scale_benchmark: --trucks and --chunk must be >= 1\n";
    return 64;
  }
  if (run.commit.empty()) run.commit = run_command("git rev-parse --short HEAD 2>/dev/null");
  if (run.commit.empty()) run.commit = "unknown";
  run.dirty = run_command("git status --porcelain -- lib 2>/dev/null | wc -l");
  if (run.dirty == "0") run.dirty.clear();
  else if (!run.dirty.empty()) run.dirty += " files under lib/ differ from HEAD";
  run.nproc = sysconf(_SC_NPROCESSORS_ONLN);
  run.started = utc_now();
  run.load_start = load_average_1min();

  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  const site::Site site(site::load_road(run.road), site::SiteOptions{});
  fleet::MarginalSmc::Options o;
  o.sampler.particles = run.particles;
  o.sampler.threads = static_cast<int>(run.threads);
  o.sampler.seed = run.seed;
  fleet::MarginalSmc smc(site, o);

  const long N = run.trucks_requested;
  run.ms.reserve(N);
  run.moves.reserve(N);
  using clock = std::chrono::steady_clock;
  const auto t_start = clock::now();
  const double cpu_start = cpu_seconds();
  double block_wall = 0.0, block_cpu_start = cpu_start;
  auto block_t0 = clock::now();
  std::string status = "complete";
  bool stopped = false;

  auto take_snapshot = [&](long n, bool with_posterior) {
    Snapshot s;
    s.n = n;
    s.elapsed_absorb_s = run.absorb_s;
    s.elapsed_wall_s = std::chrono::duration<double>(clock::now() - t_start).count();
    s.memory = memory_kb();
    s.table_bytes = smc.target().tables().bytes();
    s.table_nodes = smc.target().tables().nodes();
    s.passes = smc.target().integrator_passes();
    s.move_phases = run.move_phases;
    s.rebuilds = run.rebuilds;
    if (with_posterior) s.posterior = posterior_json(smc);
    run.snapshots.push_back(std::move(s));
  };
  auto finish_totals = [&]() {
    run.wall_s = std::chrono::duration<double>(clock::now() - t_start).count();
    run.cpu_s = cpu_seconds() - cpu_start;
  };

  long n = 0;
  for (long chunk = 0; n < N && !stopped; ++chunk) {
    const int count = static_cast<int>(std::min(run.chunk, N - n));
    const std::uint64_t chunk_seed = 1 + static_cast<std::uint64_t>(chunk);
    const auto ts0 = clock::now();
    fleet::SimulatedLog log;
    {
      const auto trucks =
          fleet::draw_fleet(fleet::FleetDistribution{}, count, site.lateral_min_m(), site.lateral_max_m(), chunk_seed);
      log = fleet::simulate_log(site, trucks, 0.02, chunk_seed);
    }
    run.simulate_s += std::chrono::duration<double>(clock::now() - ts0).count();
    block_t0 = clock::now();  // simulation is outside the block's wall too
    block_cpu_start = cpu_seconds();
    for (auto& r : log.records) {
      char id[24];
      std::snprintf(id, sizeof id, "T%07ld", n + 1);
      r.truck_id = id;
      const auto t0 = clock::now();
      const smc::StageSummary s = smc.absorb(r);
      const double dt = std::chrono::duration<double>(clock::now() - t0).count();
      ++n;
      run.absorb_s += dt;
      block_wall += dt;
      run.ms.push_back(static_cast<float>(1e3 * dt));
      int mv = 0;
      for (const auto& st : s.steps)
        if (st.resampled) {
          ++mv;
          run.mh_sweeps += st.mh.sweeps;
        }
      run.moves.push_back(static_cast<std::uint8_t>(std::min(mv, 255)));
      run.move_phases += mv;
      if (!smc.last_rebuild().empty()) {
        ++run.rebuilds;
        run.rebuild_log.push_back({n, static_cast<float>(1e3 * dt), smc.last_rebuild()});
        std::cerr << "  n=" << n << " rebuild (" << fmt(1e3 * dt, 1) << " ms): " << smc.last_rebuild() << "\n";
      }
      const bool block_end = n % 1000 == 0 || n == N;
      if (block_end) {
        run.block_wall_s.push_back(std::chrono::duration<double>(clock::now() - block_t0).count());
        run.block_cpu_s.push_back(cpu_seconds() - block_cpu_start);
        const MemoryKb m = memory_kb();
        const double el = std::chrono::duration<double>(clock::now() - t_start).count();
        std::cerr << "n=" << n << " elapsed " << fmt(el, 1) << " s (absorb " << fmt(run.absorb_s, 1)
                  << " s) trucks/s " << fmt(n / run.absorb_s, 1) << " last1000 "
                  << fmt(window_mean_ms(run.ms, n - 1000, n), 2) << " ms/truck, RSS " << fmt(m.rss / 1024.0, 1)
                  << " MiB (peak " << fmt(std::max(m.maxrss, m.hwm) / 1024.0, 1) << "), tables "
                  << fmt(smc.target().tables().bytes() / 1048576.0, 1) << " MiB, moves " << run.move_phases
                  << ", rebuilds " << run.rebuilds << ", ESS " << fmt(smc.sampler().ess(), 0) << "\n";
        block_wall = 0.0;
        block_t0 = clock::now();
        block_cpu_start = cpu_seconds();
      }
      const bool power_of_ten = n == 1000 || n == 10000 || n == 100000 || n == 1000000;
      if (power_of_ten || n == N) take_snapshot(n, n == 1000 || n == 10000 || n == N);
      if (checkpoints && (power_of_ten || (n % 10000 == 0)) && n != N) {
        finish_totals();
        write_results(run, smc, false, json_path, md_path, curve_path, per_truck_path,
                      "checkpoint at n=" + std::to_string(n) + " of " + std::to_string(N) + " (run still going)");
      }
      if (g_stop) {
        stopped = true;
        status = std::string("stopped by ") + (g_stop == SIGINT ? "SIGINT" : "SIGTERM") + " at n=" +
                 std::to_string(n) + " of " + std::to_string(N);
        std::cerr << "scale_benchmark: " << status << ", writing partial results\n";
        break;
      }
    }
  }
  if (run.snapshots.empty() || run.snapshots.back().n != n) take_snapshot(n, true);
  finish_totals();
  write_results(run, smc, !stopped, json_path, md_path, curve_path, per_truck_path, status);
  std::cerr << "done: " << n << " trucks, absorb " << fmt(run.absorb_s, 1) << " s, simulate "
            << fmt(run.simulate_s, 1) << " s, " << fmt(n / run.absorb_s, 1) << " trucks/s\n";
  return 0;
}
