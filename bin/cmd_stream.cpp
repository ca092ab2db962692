// ssrfleet stream: follow a live (or replayed) WIM record stream, update the fleet posterior
// after every truck, keep a crash-safe state directory, quarantine bad records, and print the
// SSR prediction every N trucks and at the end.
#include <signal.h>

#include <atomic>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "model/model_spec.hpp"
#include "io/site_manifest.hpp"
#include "records/vehicle_class.hpp"
#include "site/road_source.hpp"
#include "stream/wim_stream.hpp"
#include "util/errors.hpp"

namespace ssrfleet::cli {

namespace {
std::atomic<bool> g_stop{false};
extern "C" void request_stop(int) { g_stop.store(true); }

// SIGINT / SIGTERM end the stream after the record in hand; the state is saved after every
// truck, so stopping loses nothing. No SA_RESTART: a read blocked on stdin returns at once.
void install_stop_handlers() {
  struct sigaction sa {};
  sa.sa_handler = request_stop;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}
}  // namespace

int run_stream(int argc, const char* const argv[]) {
  std::string road = "AS1", input = "-", seed_text = "1", model_text = "base", classes_text, manifest_path;
  bool quiet = false;
  long particles = 1024;
  int threads = 0;
  stream::StreamOptions options;
  SiteFlags site_flags;
  po::options_description desc("stream options");
  desc.add_options()
      ("help,h", "show this help")
      ("road", po::value(&road)->value_name("ROAD")->default_value(road), kRoadHelp)
      ("sites", po::value(&manifest_path)->value_name("MANIFEST"),
       "a site manifest: one fleet from all its sites; the input's `site` column names each record's site, a record "
       "fills its site's first M value columns (the manifest's logs are not read and may be left out)")
      ("state", po::value(&options.state_dir)->value_name("DIR")->required(),
       "the stream's state directory (made if missing; an existing state is resumed): checkpoint.bin (what a resume "
       "starts from), trucks.bin (the absorbed trucks; trucks.LABEL.bin per vehicle class), posterior.json (the "
       "posterior that predict, damage and weigh read with --posterior DIR), history.sqlite (every checkpoint's "
       "summaries and SSR prediction), rejects.csv (the quarantined records) and lock (held by the running stream)")
      ("input,i", po::value(&input)->value_name("FILE")->default_value(input), "WIM log to read ('-' = standard input)")
      ("follow,f", po::bool_switch(&options.follow),
       "with --input FILE: at its end wait for more, like tail -f (stop with Ctrl-C or SIGTERM); standard input is "
       "read until it closes")
      ("report-every", po::value(&options.report_every)->value_name("N")->default_value(options.report_every),
       "print the SSR prediction every N trucks (0 = only at the end)")
      ("particles", po::value(&particles)->value_name("N")->default_value(particles), "number of particles P (>= 2)")
      ("threads", po::value(&threads)->value_name("N")->default_value(threads),
       "worker threads; 0 = all cores (results do not depend on it)")
      ("seed", po::value(&seed_text)->value_name("SEED")->default_value(seed_text),
       "random seed (a whole number; a resume must use the same one)")
      ("model", po::value(&model_text)->value_name("SPEC")->default_value(model_text),
       "the model to fit: base, or effects joined by '+', each NAME or NAME:param=value,... (a parameter given is "
       "fixed, one left out is fitted); second_class, tyre_damping, unsprung_mass and suspension_damping run on "
       "the default core, the others and compositions on the latent core; a resume must use the same model (ssrfleet effects lists "
       "them)")
      ("tables-in-memory", po::bool_switch(&options.tables_in_memory),
       "keep the marginal core's truck tables, the trucks' data and their ids in memory (about 5 KB a truck) instead of "
       "unnamed files in the state directory that the kernel pages, which keep the stream's own memory flat; same results")
      ("classes", po::value(&classes_text)->value_name("LIST"),
       "fix the vehicle classes of a new state, e.g. A,B (default: each new label in the class column starts a class of "
       "its own); a record of another class is quarantined in rejects.csv (field class); a resume keeps the state's list")
      ("fhwa-classes", po::bool_switch(&options.limits.fhwa_classes),
       "the class column must hold FHWA vehicle classes 1..13 (otherwise the record is quarantined)")
      ("quiet,q", po::bool_switch(&quiet), "no progress on standard error");
  site_flags.add_to(desc);
  po::variables_map vm;
  refuse_options(argc, argv, {{"--window", "the default (marginal) core keeps its memory per truck flat and needs no window: drop --window "
                                           "(a state written with it cannot be resumed; replay its log into a new one)"}});
  if (!parse_or_help(argc, argv, desc, nullptr, vm,
                     "ssrfleet stream --state DIR [--road ROAD | --sites MANIFEST] [--input FILE] [--follow] "
                     "[--report-every N]",
                     "The state is saved after every truck, so a stream that stops (Ctrl-C, SIGTERM, a crash) "
                     "resumes where it stopped with the same command, to the same posterior bit for bit. A second "
                     "stream on a state in use exits with status 75.")) {
    return 0;
  }
  check_particles(particles);
  // The core is chosen before the sampler options go to it (sampler() is the chosen core's).
  // The sites: --road and the site flags, or a manifest's (heap: the stream keeps pointers to them).
  ManifestSites sites;
  std::vector<stream::WimStream::StreamSite> stream_sites;
  if (manifest_path.empty()) {
    sites.sites.push_back(std::make_unique<site::Site>(site::load_road(road, &std::cerr), site_flags.to_options()));
    stream_sites.push_back({"", sites.sites.back().get(), {}});
  } else {
    refuse_beside_sites(vm, {"road", "sensors"});
    if (model_text != "base") {
      throw UsageError("--sites streams the base model on the marginal core (each truck's table built through its own "
                       "site); --model with an effect streams one site");
    }
    const io::SiteManifest manifest = io::read_site_manifest(manifest_path);
    sites = build_manifest_sites(manifest, site_flags, &std::cerr);
    for (std::size_t s = 0; s < manifest.sites.size(); ++s) {
      const io::ManifestSite& entry = manifest.sites[s];
      Eigen::VectorXd gains;  // none: the state keeps naming the site as before calibrations
      if (!entry.calibration.empty()) gains = manifest_sensor_gains(entry, sites.sites[s]->sensors());
      stream_sites.push_back({entry.name, sites.sites[s].get(), gains});
    }
  }
  const site::Site& site = *sites.sites.front();
  const fleet::ModelSpec model = fleet::parse_model_spec(model_text, site);
  options.fit.core = fleet::choose_core(model.extension.get());
  options.fit.extension = model.extension.get();
  options.fit.sampler().particles = particles;
  options.fit.sampler().threads = threads > 0 ? threads : smc::TemperedSampler::Options::default_threads();
  options.fit.sampler().seed = parse_seed(seed_text);
  std::string why;
  if (!options.fit.sampler().IsValid(&why)) throw UsageError(why);
  if (!classes_text.empty()) {
    std::stringstream ss(classes_text);
    std::string label;
    while (std::getline(ss, label, ',')) {
      if (!records::is_class_label(label)) {
        throw UsageError("--classes '" + classes_text + "': '" + label + "' is not a class label (one or more of A-Z a-z 0-9 _ . -)");
      }
      if (options.limits.fhwa_classes && !records::is_fhwa_class(label)) {
        throw UsageError("--classes '" + classes_text + "': '" + label + "' is not an FHWA class (1 to 13)");
      }
      options.classes.insert(label);
    }
    if (options.classes.empty()) throw UsageError("--classes '" + classes_text + "': no class labels");
  }
  if (options.follow && input == "-") throw UsageError("--follow needs --input FILE (standard input follows by itself)");

  install_stop_handlers();
  stream::WimStream stream(stream_sites, options, quiet ? nullptr : &std::cerr, std::cout);
  std::ifstream file;
  if (input != "-") {
    file.open(input);
    if (!file) throw MissingInputError("cannot open WIM log '" + input + "'");
  }
  const auto counts = stream.run(input == "-" ? std::cin : file, input == "-" ? "<stdin>" : input, g_stop);
  std::cerr << "ssrfleet stream: " << counts.absorbed << " trucks absorbed, " << counts.rejected << " rejected (see "
            << options.state_dir << "/rejects.csv), " << counts.skipped << " skipped as already absorbed; "
            << counts.total_absorbed << " trucks in the posterior" << (g_stop.load() ? " (stopped by signal)" : "")
            << "\n";
  if (const std::string w = stream.warning(); !w.empty()) std::cerr << "ssrfleet stream: warning: " << w << "\n";
  return 0;
}

}  // namespace ssrfleet::cli
