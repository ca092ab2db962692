#include "stream/wim_stream.hpp"

#include "fleet/joint_sites.hpp"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <thread>

#include "fleet/posterior_summary.hpp"
#include "io/atomic_file.hpp"
#include "io/posterior_json.hpp"
#include "io/wim_log.hpp"
#include "io/write_faults.hpp"
#include "stream/history_rows.hpp"
#include "util/free_memory.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"
#include "util/stop_token.hpp"

namespace ssrfleet::stream {

namespace fs = std::filesystem;

namespace {
std::string path_in(const std::string& dir, const char* name) { return (fs::path(dir) / name).string(); }

// The posteriors of a stream of several sites seen from its first site (its own traffic and class
// shares; the whole's shares while it has no trucks yet); one site's as they are.
fleet::ClassPosteriors at_first_site(fleet::ClassPosteriors classes) {
  const fleet::ClassPosteriors whole = classes;
  long at_site = 0;
  for (auto& c : classes) {
    if (c.cloud.sites.empty()) return classes;
    c.cloud = fleet::cloud_at_site(c.cloud, 0);
    at_site += c.cloud.trucks_seen;
  }
  if (at_site == 0) {
    for (std::size_t k = 0; k < classes.size(); ++k) classes[k].cloud.trucks_seen = whole[k].cloud.trucks_seen;
  }
  return classes;
}
// The stream checkpoint's header (bookkeeping first, then the core's state, with the marginal
// core's truck log beside it), sealed with a checksum (binary_io.hpp). Version 4 holds a core per
// vehicle class (class_cores.hpp), the checkpoint's sequence number (the history names it) and
// truck logs with a generation header; version 3 recorded the model and carried the checksums;
// version 2 had neither; version 1 began with the core's own magic word. Version 5 names the
// stream's sites after the model (a version-4 state is one unnamed site's, and reads as that).
constexpr std::uint64_t kStreamMagic = 0x4d52545346525353ULL;       // "SSRFSTRM"
constexpr std::uint32_t kStreamVersion = 5;
constexpr std::uint64_t kOldCheckpointMagic = 0x54504b4346525353ULL;  // "SSRFCKPT"
// How often (in trucks) a stream hands the heap's free pages back: one walk of a heap of some tens
// of MB per 256 trucks, each of which takes tens of milliseconds.
constexpr long kTrimEvery = 256;

// The cores' options: the marginal core's tables, data and ids grow by about 5 kB a truck; in
// unnamed files in the state directory (model/table_store.hpp) they leave the stream's own memory flat.
fleet::OnlineFitOptions fit_options(const StreamOptions& o) {
  fleet::OnlineFitOptions fit = o.fit;
  if (!o.tables_in_memory) fit.marginal.target.table_spill_directory = o.state_dir;
  return fit;
}

}  // namespace

WimStream::WimStream(std::vector<StreamSite> sites, StreamOptions options, std::ostream* progress, std::ostream& reports)
    : sites_(std::move(sites)),
      site_(sites_.empty() || sites_.front().site == nullptr ? throw UsageError("stream: no site") : *sites_.front().site),
      options_(std::move(options)),
      progress_(progress),
      reports_(reports),
      cores_(site_pointers(), fit_options(options_), options_.state_dir) {
  fleet::make_online_fit(site_pointers(), options_.fit);  // UsageError now on bad options, as before classes
  for (const auto& s : sites_) {
    if (s.calibration.size() > 0 && s.calibration.size() != s.site->sensors()) {
      throw UsageError("stream: site '" + s.name + "' has " + std::to_string(s.calibration.size()) + " gains for " +
                       std::to_string(s.site->sensors()) + " sensors");
    }
    if (s.calibration.size() > 0 && !(s.calibration.array() > 0.0).all()) {
      throw UsageError("stream: site '" + s.name + "': a sensor gain must be positive");
    }
  }
  if (options_.state_dir.empty()) throw UsageError("stream: a state directory is required (--state DIR)");
  if (options_.report_every < 0) throw UsageError("stream: --report-every must be >= 0");
  std::error_code ec;
  fs::create_directories(options_.state_dir, ec);
  if (ec || !fs::is_directory(options_.state_dir)) {
    throw IoError("stream: cannot create the state directory '" + options_.state_dir + "': " + ec.message());
  }
  // One writer per state: taken before anything in the directory is read or written.
  lock_ = std::make_unique<StateLock>(options_.state_dir);
  const std::string checkpoint = path_in(options_.state_dir, "checkpoint.bin");
  if (fs::exists(checkpoint)) restore_checkpoint(checkpoint);
  open_history();
  if (resumed_ && posterior_seq_ != seq_) {
    // posterior.json may lag the checkpoint if the last run failed after the history's commit.
    write_posterior(posteriors());
  }
  if (resumed_ && progress_) {
    *progress_ << "stream: resumed from " << checkpoint << " with " << cores_.trucks_seen() << " trucks absorbed"
               << (cores_.labelled() ? " in classes " + cores_.labels() : std::string()) << "\n";
  }
}

std::vector<std::string> WimStream::site_names() const {
  std::vector<std::string> names;
  for (const auto& s : sites_) names.push_back(s.name);
  return names;
}

std::vector<std::string> WimStream::site_identities() const {
  std::vector<std::string> names;
  for (const auto& s : sites_) {
    std::ostringstream id;
    id << s.name;
    if (s.calibration.size() > 0) {
      id << " (calibration" << std::setprecision(17);
      for (Eigen::Index j = 0; j < s.calibration.size(); ++j) id << (j ? "," : " ") << s.calibration[j];
      id << ")";
    }
    names.push_back(id.str());
  }
  return names;
}

std::vector<fleet::SiteCalibration> WimStream::calibration() const {
  std::vector<fleet::SiteCalibration> out;
  bool any = false;
  for (const auto& s : sites_) {
    const Eigen::VectorXd g = s.calibration.size() > 0 ? s.calibration : Eigen::VectorXd::Ones(s.site->sensors());
    out.push_back({s.name, std::vector<double>(g.data(), g.data() + g.size()), {}});
    any = any || s.calibration.size() > 0;
  }
  if (!any) out.clear();
  return out;
}

std::vector<const site::Site*> WimStream::site_pointers() const {
  std::vector<const site::Site*> p;
  for (const auto& s : sites_) {
    if (s.site == nullptr) throw UsageError("stream: a site is missing");
    p.push_back(s.site);
  }
  return p;
}

fleet::ClassPosteriors WimStream::posteriors() const {
  fleet::ClassPosteriors classes = cores_.posteriors();
  for (auto& c : classes) {
    for (std::size_t s = 0; s < c.cloud.sites.size() && s < sites_.size(); ++s) c.cloud.sites[s].name = sites_[s].name;
    c.cloud.calibration = calibration();
  }
  return classes;
}

void WimStream::restore_checkpoint(const std::string& checkpoint) {
  std::ifstream in(checkpoint, std::ios::binary);
  if (!in) throw IoError("stream: cannot read '" + checkpoint + "'");
  BinaryReader reader(in, checkpoint);
  const auto magic = reader.value<std::uint64_t>("magic");
  if (magic == kOldCheckpointMagic) {
    reader.fail("format", "stream state format version 1 (ssrfleet 0.1, latent core, before the truck log): this build "
                          "writes version " + std::to_string(kStreamVersion) + "; replay the log into a new state directory");
  }
  if (magic != kStreamMagic) reader.fail("magic", "not an ssrfleet stream checkpoint");
  const auto version = reader.value<std::uint32_t>("version");
  if (version != kStreamVersion && version != 4) {
    const char* what = version == 2 ? " (before checksums and models)"
                       : version == 3 ? " (before vehicle classes and the history)"
                                      : "";
    reader.fail("version", "stream state format version " + std::to_string(version) + what + ", this build reads " +
                               std::to_string(kStreamVersion) + ": replay the log into a new state directory");
  }
  checkpoint_source_ = reader.text("source");
  const std::string state_model = reader.text("model");
  if (state_model != model_text()) {
    reader.fail("model", "the state was written with --model " + state_model + "; resume it with the same model (this "
                         "run asks for " + model_text() + ")");
  }
  std::vector<std::string> state_sites{""};
  if (version >= 5) {
    const auto n = reader.value<std::uint64_t>("sites");
    if (n < 1 || n > 100000) reader.fail("sites", "implausible site count " + std::to_string(n));
    state_sites.clear();
    for (std::uint64_t s = 0; s < n; ++s) state_sites.push_back(reader.text("site"));
  }
  if (state_sites != site_identities()) {
    const auto list = [](const std::vector<std::string>& names) {
      if (names.size() == 1 && names.front().empty()) return std::string("one site (no manifest)");
      std::string out = "sites ";
      for (std::size_t s = 0; s < names.size(); ++s) out += (s ? ", " : "") + names[s];
      return out;
    };
    reader.fail("sites", "the state was made with " + list(state_sites) + "; resume it with the same ones, in the same "
                         "order (this run has " + list(site_identities()) + ")");
  }
  seq_ = reader.value<std::uint64_t>("seq");
  checkpoint_lines_ = reader.value<std::uint64_t>("lines_consumed");
  rejects_bytes_ = reader.value<std::uint64_t>("rejects_bytes");
  const bool split = reader.value<std::uint8_t>("split") != 0;
  cores_.restore(reader, split);
  reader.check_seal("checkpoint");
  checkpoint_checksum_ = reader.last_seal();
  cores_.check_counts(reader);
  if (!options_.classes.empty() && options_.classes != cores_.fixed()) {
    std::string fixed;
    for (const auto& c : cores_.fixed()) fixed += (fixed.empty() ? "" : ",") + c;
    throw UsageError("stream: the state in '" + options_.state_dir + "' was made with " +
                     (fixed.empty() ? std::string("no fixed classes") : "--classes " + fixed) +
                     "; a resume keeps its classes (leave --classes out or give the same list)");
  }
  resumed_ = true;
  // Records rejected after the checkpoint will be read and rejected again: cut them off here so
  // rejects.csv lists each bad record once.
  const std::string rejects = path_in(options_.state_dir, "rejects.csv");
  if (fs::exists(rejects) && fs::file_size(rejects) > rejects_bytes_) fs::resize_file(rejects, rejects_bytes_);
}

// The history must end at this checkpoint, or one short of it (a failure between the checkpoint's
// rename and the history's commit): then the missing row set is written now, from the restored
// cloud, exactly as the interrupted run would have written it.
void WimStream::open_history() {
  history_ = std::make_unique<io::HistoryDb>(path_in(options_.state_dir, "history.sqlite"), model_text());
  const std::uint64_t have = history_->last_seq().value_or(0);
  if (have == seq_) {
    if (seq_ > 0 && history_->read_report(seq_).checkpoint_checksum != checkpoint_checksum_) {
      throw DataError(history_->path(), 0, "checkpoint_checksum",
                      "report " + std::to_string(seq_) + " names another checkpoint.bin than the one in the state "
                      "directory: history and checkpoint disagree");
    }
    return;
  }
  if (have + 1 == seq_) {
    if (have > 0) history_->read_report(have);  // its checksum, before building on it
    write_history_and_posterior(checkpoint_source_, checkpoint_lines_);
    return;
  }
  throw DataError(history_->path(), 0, "seq",
                  "the history ends at report " + std::to_string(have) + " but the checkpoint is number " +
                      std::to_string(seq_) + ": history and checkpoint disagree (was one of them replaced?)");
}

void WimStream::save_state(const std::string& source, std::size_t lines_consumed) {
  // The truck logs first (class_cores.hpp), then the checkpoint that counts them: the stream's
  // bookkeeping and every class's core; then the logs rewritten after a table rebuild take their
  // place, and the history and posterior.json follow.
  cores_.write_logs();
  io::write_file_atomically(path_in(options_.state_dir, "checkpoint.bin"), [&](std::ostream& os) {
    BinaryWriter out(os);
    out.value(kStreamMagic);
    out.value(kStreamVersion);
    out.text(source);
    out.text(model_text());
    out.value<std::uint64_t>(sites_.size());
    for (const std::string& site : site_identities()) out.text(site);
    out.value<std::uint64_t>(seq_ + 1);
    out.value<std::uint64_t>(lines_consumed);
    out.value<std::uint64_t>(rejects_bytes_);
    out.value<std::uint8_t>(cores_.splits_state() ? 1 : 0);
    cores_.save(out);
    out.seal();
    checkpoint_checksum_ = out.last_seal();
  });
  ++seq_;
  cores_.commit_logs();
  write_history_and_posterior(source, lines_consumed);
}

void WimStream::write_history_and_posterior(const std::string& source, std::size_t lines_consumed) {
  const fleet::ClassPosteriors classes = posteriors();
  const HistoryRowsInput row{.seq = seq_, .source = source, .lines_consumed = lines_consumed,
                             .checkpoint_checksum = checkpoint_checksum_};
  // Over several sites, the trucks and θ summaries are the fleet's, the predictions the first site's.
  const fleet::ClassPosteriors first = at_first_site(classes);
  history_->append(history_rows(classes, site_, options_.history_prediction, row, &first));
  write_posterior(classes);
}

void WimStream::write_posterior(const fleet::ClassPosteriors& classes) {
  posterior_seq_ = seq_;
  std::vector<std::vector<fleet::ParameterSummary>> hyper, psi;
  for (const auto& c : classes) {
    hyper.push_back(fleet::summarise_cloud(c.cloud));
    psi.push_back(fleet::summarise_psi(c.cloud));
  }
  io::write_posterior_classes_file(path_in(options_.state_dir, "posterior.json"), classes, hyper, psi);
}

void WimStream::report() const {
  if (cores_.trucks_seen() == 0) return;
  // With classes: the mixture at the observed traffic shares (predict_ssr_mixture; one
  // unlabelled class is predict_ssr itself).
  const fleet::ClassPosteriors classes = at_first_site(posteriors());
  const auto prediction =
      predict::predict_ssr_mixture(classes, fleet::observed_shares(classes), site_, {}, options_.prediction);
  reports_ << "# SSR prediction after " << cores_.trucks_seen() << " trucks";
  if (sites_.size() > 1) reports_ << " of " << sites_.size() << " sites, at site " << sites_.front().name;
  if (cores_.labelled()) reports_ << " (classes " << cores_.labels() << " at their observed shares)";
  reports_ << "\n";
  predict::write_prediction_csv(reports_, prediction);
  reports_.flush();
}

StreamCounts WimStream::run(std::istream& in, const std::string& source, const std::atomic<bool>& stop) {
  io::WimLogReader reader(in, source, site_.options().unsprung_mass_kg, options_.limits);
  if (sites_.size() > 1 || !sites_.front().name.empty()) {  // a manifest's sites, even one
    std::vector<io::WimLogReader::LogSite> log_sites;
    for (const auto& s : sites_) log_sites.push_back({s.name, s.site->sensors()});
    reader.set_sites(std::move(log_sites));
  } else if (reader.sensors() != site_.sensors()) {
    throw DataError(source, reader.header_line_number(), "if_" + std::to_string(reader.sensors()),
                    "the input has " + std::to_string(reader.sensors()) + " sensors but the site has " +
                        std::to_string(site_.sensors()));
  }
  // Vehicle classes: a state holds labelled classes or one unlabelled posterior, never both.
  if (!cores_.empty() && cores_.labelled() != reader.has_classes()) {
    throw DataError(source, reader.header_line_number(), "class",
                    cores_.labelled() ? "the input has no class column, but the state holds classes " + cores_.labels()
                                      : std::string("the input has a class column, but the state's posterior has no "
                                                    "classes (replay into a new state directory)"));
  }
  if (!resumed_) cores_.set_fixed(options_.classes);
  if (!cores_.fixed().empty() && !reader.has_classes()) {
    throw DataError(source, reader.header_line_number(), "class", "the state's classes are fixed (--classes), but the input has no class column");
  }
  reader.set_classes(cores_.fixed());
  reader.set_follow(options_.follow);
  const bool same_source = resumed_ && source == checkpoint_source_;
  // The ids absorbed before this run (a resume skips their records), and every id the reader has
  // seen (a duplicate is rejected): both grow with the trucks, so both live in spill files in the
  // state directory, like the tables, unless --tables-in-memory.
  const std::string spill_directory = options_.tables_in_memory ? std::string() : options_.state_dir;
  const util::SpillStringSet absorbed_before = cores_.truck_ids(spill_directory);
  reader.keep_ids_in(spill_directory);

  const std::string rejects_path = path_in(options_.state_dir, "rejects.csv");
  std::ofstream rejects(rejects_path, std::ios::app | std::ios::binary);
  if (!rejects) throw IoError("stream: cannot open '" + rejects_path + "' for appending");
  if (fs::file_size(rejects_path) == 0) {
    rejects << "# records rejected by ssrfleet stream, verbatim, each after its reason\n" << reader.header_line() << "\n";
    rejects.flush();
  }
  rejects_bytes_ = fs::file_size(rejects_path);

  StreamCounts counts;
  records::WimRecord record;
  io::Rejection why;
  long reported_at = -1;  // the truck count of the last --report-every report
  for (;;) {
    if (stop.load() || util::stop_requested()) break;  // after the record in hand, its state saved
    const auto status = reader.next(record, why);
    if (status == io::WimLogReader::Status::end) {
      if (!options_.follow || stop.load()) break;
      in.clear();
      std::this_thread::sleep_for(std::chrono::duration<double>(options_.follow_poll_s));
      continue;
    }
    const std::size_t line = status == io::WimLogReader::Status::record ? record.line : why.line;
    if (same_source && line <= checkpoint_lines_) continue;  // handled before the restart
    if (status == io::WimLogReader::Status::rejected) {
      ++counts.rejected;
      io::check_write_fault(rejects_path);
      rejects << "# line " << why.line << ": " << why.field << ": " << why.reason << "\n" << why.raw << "\n";
      rejects.flush();
      if (!rejects) throw IoError("stream: writing '" + rejects_path + "' failed");
      rejects_bytes_ = fs::file_size(rejects_path);
      if (progress_) *progress_ << "stream: rejected " << why.message << "\n";
      continue;
    }
    if (absorbed_before.contains(record.truck_id)) {
      ++counts.skipped;
      continue;
    }
    if (const Eigen::VectorXd& gains = sites_.at(record.site).calibration; gains.size() > 0) {
      fleet::remove_sensor_gains(record, gains);
    }
    fleet::OnlineFit& core = cores_.core(record.vehicle_class);
    const auto& stage = core.absorb(record);
    ++counts.absorbed;
    save_state(source, line);
    // Every so many trucks the heap's free pages go back to the kernel (util/free_memory.hpp), so
    // the resident set follows the memory in use, which does not grow with the trucks.
    if (cores_.trucks_seen() % kTrimEvery == 0) util::return_free_memory();
    if (progress_) {
      *progress_ << "stream: truck " << cores_.trucks_seen() << " " << record.truck_id << " (line " << line << ")"
                 << (record.vehicle_class.empty() ? "" : " class " + record.vehicle_class) << ": "
                 << stage.steps.size() << " steps, ESS " << std::fixed << std::setprecision(0) << core.sampler().ess()
                 << ", " << std::setprecision(3) << stage.wall_time_s << " s";
      const std::string note = core.note();
      *progress_ << (note.empty() ? "" : "; ") << note << "\n";
      progress_->unsetf(std::ios::floatfield);
    }
    if (options_.report_every > 0 && cores_.trucks_seen() % options_.report_every == 0) {
      report();
      reported_at = cores_.trucks_seen();
    }
  }
  // The end of input reports the posterior once, not again when the last truck's report was due.
  if (cores_.trucks_seen() != reported_at) report();
  counts.total_absorbed = cores_.trucks_seen();
  return counts;
}

}  // namespace ssrfleet::stream
