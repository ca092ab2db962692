// ssrfleet serve: a live web page and a JSON API over one or more stream state directories,
// read-only (lib/serve, docs/serve.md). The sites come from the same flags as stream's: --road and
// the site flags for a stream of one site, --sites MANIFEST for a joint stream.
#include <signal.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <filesystem>
#include <iostream>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "io/site_manifest.hpp"
#include "serve/server.hpp"
#include "site/road_source.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

namespace {

// The API's name for a state: its directory's last component, made unique and kept to the
// characters a query label allows.
std::vector<std::string> state_names(const std::vector<std::string>& dirs) {
  std::vector<std::string> names;
  std::set<std::string> taken;
  for (const auto& dir : dirs) {
    std::string base = std::filesystem::path(dir).lexically_normal().filename().string();
    if (base.empty() || base == ".") base = std::filesystem::absolute(dir).lexically_normal().parent_path().filename().string();
    std::string name;
    for (const char c : base) {
      const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '.' || c == '-';
      name.push_back(ok ? c : '_');
    }
    if (name.empty()) name = "state";
    name = name.substr(0, 56);
    std::string unique = name;
    for (int k = 2; taken.count(unique) > 0; ++k) unique = name + "-" + std::to_string(k);
    taken.insert(unique);
    names.push_back(unique);
  }
  return names;
}

}  // namespace

int run_serve(int argc, const char* const argv[]) {
  std::vector<std::string> dirs;
  std::string road = "AS1", manifest_path;
  serve::ServeOptions options;
  SiteFlags site_flags;
  po::options_description desc("serve options");
  desc.add_options()
      ("help,h", "show this help")
      ("state", po::value(&dirs)->value_name("DIR")->required()->composing(),
       "a stream's state directory to follow (repeat for several streams); read-only: history.sqlite is opened "
       "read-only, rejects.csv and posterior.json are read, the lock is never opened")
      ("road", po::value(&road)->value_name("ROAD")->default_value(road), kRoadHelp)
      ("sites", po::value(&manifest_path)->value_name("MANIFEST"),
       "the site manifest of a joint stream (stream --sites): the page offers each of its sites")
      ("bind", po::value(&options.bind)->value_name("ADDRESS")->default_value(options.bind),
       "the address to listen on (0.0.0.0: every interface; the page and API have no authentication)")
      ("port", po::value(&options.port)->value_name("PORT")->default_value(options.port),
       "the TCP port (0: any free one, printed at start)")
      ("rate-limit", po::value(&options.rate_per_s)->value_name("N")->default_value(options.rate_per_s),
       "requests a second per client address, in bursts of up to twice as many (0: no limit); the page, polling "
       "every second, makes at most 6")
      ("http-threads", po::value(&options.http_threads)->value_name("N")->default_value(options.http_threads),
       "threads answering requests")
      ("idle-after", po::value(&options.idle_after_s)->value_name("S")->default_value(options.idle_after_s),
       "a running stream with no checkpoint for S seconds is shown as idle");
  site_flags.add_to(desc);
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, nullptr, vm,
                     "ssrfleet serve --state DIR [--state DIR ...] [--road ROAD | --sites MANIFEST] [--bind ADDRESS] "
                     "[--port PORT]",
                     "Open http://ADDRESS:PORT/ in a browser: the SSR pattern along the array with its 95 % limits, "
                     "the hyperparameters against trucks absorbed, trucks per minute, the last rejected records and "
                     "the damage hot spots, updated within 2 s of each checkpoint. A stream is shown as stopped when "
                     "no process holds its lock (/proc/locks). The JSON API is in docs/serve.md.")) {
    return 0;
  }
  if (options.port < 0 || options.port > 65535) throw UsageError("--port must be in [0, 65535]");
  if (!(options.rate_per_s >= 0.0)) throw UsageError("--rate-limit must be >= 0");
  if (options.http_threads < 1 || options.http_threads > 256) throw UsageError("--http-threads must be in [1, 256]");
  if (!(options.idle_after_s > 0.0)) throw UsageError("--idle-after must be > 0");
  options.burst = std::max(1.0, 2.0 * options.rate_per_s);
  for (const auto& dir : dirs) {
    // A state that is not there yet is waited for (serve may start before its stream); a file is a mistake.
    if (std::filesystem::exists(dir) && !std::filesystem::is_directory(dir)) {
      throw UsageError("--state '" + dir + "' is not a directory");
    }
    if (!std::filesystem::exists(dir)) {
      std::cerr << "ssrfleet serve: '" << dir << "' does not exist yet: shown as waiting until a stream makes it\n";
    }
  }
  ManifestSites sites;
  std::vector<serve::ServedSite> served_sites;
  if (manifest_path.empty()) {
    sites.sites.push_back(std::make_unique<site::Site>(site::load_road(road, &std::cerr), site_flags.to_options()));
    served_sites.push_back({"", sites.sites.back().get()});
  } else {
    refuse_beside_sites(vm, {"road", "sensors"});
    const io::SiteManifest manifest = io::read_site_manifest(manifest_path);
    sites = build_manifest_sites(manifest, site_flags, &std::cerr);
    for (std::size_t s = 0; s < manifest.sites.size(); ++s) served_sites.push_back({manifest.sites[s].name, sites.sites[s].get()});
  }
  const std::vector<std::string> names = state_names(dirs);
  std::vector<serve::StateConfig> states;
  for (std::size_t i = 0; i < dirs.size(); ++i) states.push_back({names[i], dirs[i], served_sites});

  // SIGINT and SIGTERM end the server: blocked here (every thread started later inherits the
  // mask) and taken by one thread with sigwait, which may call stop() safely.
#if defined(__GLIBC__)
  // glibc gives each thread that allocates an arena of its own, up to 8 per core, and each keeps
  // what its thread freed: with a dozen threads that is most of the server's memory. Two suffice for
  // a server whose threads each hold a request for a millisecond.
  mallopt(M_ARENA_MAX, 2);
#endif
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  serve::Server server(std::move(states), options);
  const int port = server.bind();
  std::cerr << "ssrfleet serve: http://" << options.bind << ":" << port << "/ following";
  for (std::size_t i = 0; i < dirs.size(); ++i) std::cerr << " " << names[i] << " (" << dirs[i] << ")";
  std::cerr << std::endl;
  std::thread waiter([&] {
    int signal = 0;
    sigwait(&stop_signals, &signal);
    server.stop();
  });
  server.run();
  // Ended by a signal, or by the listener failing: either way make the waiter return.
  pthread_kill(waiter.native_handle(), SIGTERM);
  waiter.join();
  std::cerr << "ssrfleet serve: stopped" << std::endl;
  return 0;
}

}  // namespace ssrfleet::cli
