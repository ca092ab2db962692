#include "stream/wim_stream.hpp"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <thread>
#include <unordered_set>

#include "fleet/posterior_summary.hpp"
#include "io/atomic_file.hpp"
#include "io/posterior_json.hpp"
#include "io/wim_log.hpp"
#include "io/write_faults.hpp"
#include "stream/history_rows.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

namespace ssrfleet::stream {

namespace fs = std::filesystem;

namespace {
std::string path_in(const std::string& dir, const char* name) { return (fs::path(dir) / name).string(); }
// The stream checkpoint's header (bookkeeping first, then the core's state, with the marginal
// core's truck log beside it), sealed with a checksum (binary_io.hpp). Version 4 adds the
// checkpoint's sequence number (the history names it) and the truck log's generation header;
// version 3 recorded the model and carried the checksums; version 2 had neither; version 1 began
// with the core's own magic word.
constexpr std::uint64_t kStreamMagic = 0x4d52545346525353ULL;       // "SSRFSTRM"
constexpr std::uint32_t kStreamVersion = 4;
constexpr std::uint64_t kOldCheckpointMagic = 0x54504b4346525353ULL;  // "SSRFCKPT"
constexpr std::uint64_t kTruckLogMagic = 0x534b525446525353ULL;       // "SSRFTRKS"

// The truck log's header: which generation of tables its records hold.
void write_truck_log_header(BinaryWriter& out, std::int32_t generation) {
  out.value(kTruckLogMagic);
  out.value(generation);
  out.seal();
}
std::int32_t read_truck_log_header(BinaryReader& in) {
  if (in.value<std::uint64_t>("magic") != kTruckLogMagic) in.fail("magic", "not an ssrfleet truck log");
  const auto generation = in.value<std::int32_t>("generation");
  in.check_seal("header");
  return generation;
}
std::int32_t truck_log_generation(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError("stream: cannot read '" + path + "'");
  BinaryReader reader(in, path);
  return read_truck_log_header(reader);
}
}  // namespace

WimStream::WimStream(const site::Site& site, StreamOptions options, std::ostream* progress, std::ostream& reports)
    : site_(site), options_(std::move(options)), progress_(progress), reports_(reports), smc_(fleet::make_online_fit(site, options_.fit)) {
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
  const bool caught_up = open_history();
  if (resumed_ && !caught_up) {
    // posterior.json may lag the checkpoint if the last run failed after the history's commit.
    const fleet::PosteriorCloud cloud = smc_->cloud();
    io::write_posterior_file(path_in(options_.state_dir, "posterior.json"), cloud, fleet::summarise_cloud(cloud),
                             fleet::summarise_psi(cloud));
  }
  if (resumed_ && progress_) {
    *progress_ << "stream: resumed from " << checkpoint << " with " << smc_->trucks_seen() << " trucks absorbed\n";
  }
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
  if (version != kStreamVersion) {
    const char* what = version == 2 ? " (before checksums and models)" : version == 3 ? " (before the history)" : "";
    reader.fail("version", "stream state format version " + std::to_string(version) + what + ", this build reads " +
                               std::to_string(kStreamVersion) + ": replay the log into a new state directory");
  }
  checkpoint_source_ = reader.text("source");
  const std::string state_model = reader.text("model");
  if (state_model != model_text()) {
    reader.fail("model", "the state was written with --model " + state_model + "; resume it with the same model (this "
                         "run asks for " + model_text() + ")");
  }
  seq_ = reader.value<std::uint64_t>("seq");
  checkpoint_lines_ = reader.value<std::uint64_t>("lines_consumed");
  rejects_bytes_ = reader.value<std::uint64_t>("rejects_bytes");
  const bool split = reader.value<std::uint8_t>("split") != 0;
  trucks_written_ = reader.value<std::uint64_t>("trucks_written");
  trucks_bytes_ = reader.value<std::uint64_t>("trucks_bytes");
  trucks_generation_ = reader.value<std::int32_t>("trucks_generation");
  if (split != smc_->splits_state()) {
    reader.fail("core", std::string("the state was written by the ") + (split ? "marginal" : "latent") +
                            " core; resume it with the same core (--window selects the latent one)");
  }
  if (split) {
    restore_truck_log(reader);
  } else {
    smc_->restore(reader);
  }
  reader.check_seal("checkpoint");
  checkpoint_checksum_ = reader.last_seal();
  if (split && static_cast<std::uint64_t>(smc_->trucks_seen()) != trucks_written_) {
    reader.fail("trucks_written", "the checkpoint and the truck log disagree on the truck count");
  }
  resumed_ = true;
  // Records rejected after the checkpoint will be read and rejected again: cut them off here so
  // rejects.csv lists each bad record once.
  const std::string rejects = path_in(options_.state_dir, "rejects.csv");
  if (fs::exists(rejects) && fs::file_size(rejects) > rejects_bytes_) fs::resize_file(rejects, rejects_bytes_);
}

// Brings trucks.bin to the checkpoint's generation and length, then restores the core from both.
void WimStream::restore_truck_log(BinaryReader& checkpoint) {
  const std::string log = path_in(options_.state_dir, "trucks.bin");
  const std::string next = log + ".next";
  if (fs::exists(next)) {
    // A rewrite that stopped before its rename: finish it if the checkpoint already names it,
    // drop it if the checkpoint never got that far.
    if (truck_log_generation(next) == trucks_generation_) {
      fs::rename(next, log);
    } else {
      fs::remove(next);
    }
  }
  if (!fs::exists(log) || fs::file_size(log) < trucks_bytes_) {
    checkpoint.fail("trucks_bytes", "'" + log + "' is missing or shorter than the checkpoint says (" +
                                        std::to_string(trucks_bytes_) + " bytes)");
  }
  // A crash between appending to the truck log and this checkpoint leaves a tail: cut it off.
  if (fs::file_size(log) > trucks_bytes_) fs::resize_file(log, trucks_bytes_);
  std::ifstream trucks_in(log, std::ios::binary);
  if (!trucks_in) throw IoError("stream: cannot read '" + log + "'");
  BinaryReader trucks(trucks_in, log);
  const std::int32_t generation = read_truck_log_header(trucks);
  if (generation != trucks_generation_) {
    trucks.fail("generation", "the truck log holds tables of generation " + std::to_string(generation) +
                                  ", the checkpoint names generation " + std::to_string(trucks_generation_));
  }
  smc_->restore_split(checkpoint, trucks);
}

// The history must end at this checkpoint, or one short of it (a failure between the checkpoint's
// rename and the history's commit): then the missing row set is written now, from the restored
// cloud, exactly as the interrupted run would have written it (and posterior.json with it: true).
bool WimStream::open_history() {
  history_ = std::make_unique<io::HistoryDb>(path_in(options_.state_dir, "history.sqlite"), model_text());
  const std::optional<std::uint64_t> last = history_->last_seq();
  const std::uint64_t have = last.value_or(0);
  if (have == seq_) {
    if (seq_ > 0 && history_->read_report(seq_).checkpoint_checksum != checkpoint_checksum_) {
      throw DataError(history_->path(), 0, "checkpoint_checksum",
                      "report " + std::to_string(seq_) + " names another checkpoint.bin than the one in the state "
                      "directory: history and checkpoint disagree");
    }
    return false;
  }
  if (have + 1 == seq_) {
    if (have > 0) history_->read_report(have);  // its checksum, before building on it
    write_history_and_posterior(checkpoint_source_, checkpoint_lines_);
    return true;
  }
  throw DataError(history_->path(), 0, "seq",
                  "the history ends at report " + std::to_string(have) + " but the checkpoint is number " +
                      std::to_string(seq_) + ": history and checkpoint disagree (was one of them replaced?)");
}

void WimStream::save_state(const std::string& source, std::size_t lines_consumed) {
  bool rewrote_log = false;
  const std::string log = path_in(options_.state_dir, "trucks.bin");
  if (smc_->splits_state()) {
    const auto n = static_cast<std::uint64_t>(smc_->trucks_seen());
    if (smc_->table_generation() != trucks_generation_ || trucks_written_ > n) {
      // New tables: a whole new log beside the old one, which stays until the checkpoint names it.
      trucks_generation_ = smc_->table_generation();
      io::write_file_atomically(log + ".next", [&](std::ostream& os) {
        BinaryWriter out(os);
        write_truck_log_header(out, trucks_generation_);
        smc_->save_trucks(out, 0, n);
      });
      trucks_bytes_ = fs::file_size(log + ".next");
      rewrote_log = true;
    } else if (n > trucks_written_) {
      std::ostringstream records;
      BinaryWriter out(records);
      smc_->save_trucks(out, trucks_written_, n);
      io::append_file_synced(log, records.str());
      trucks_bytes_ += records.str().size();
    }
    trucks_written_ = n;
  }
  io::write_file_atomically(path_in(options_.state_dir, "checkpoint.bin"), [&](std::ostream& os) {
    BinaryWriter out(os);
    out.value(kStreamMagic);
    out.value(kStreamVersion);
    out.text(source);
    out.text(model_text());
    out.value<std::uint64_t>(seq_ + 1);
    out.value<std::uint64_t>(lines_consumed);
    out.value<std::uint64_t>(rejects_bytes_);
    out.value<std::uint8_t>(smc_->splits_state() ? 1 : 0);
    out.value<std::uint64_t>(trucks_written_);
    out.value<std::uint64_t>(trucks_bytes_);
    out.value<std::int32_t>(trucks_generation_);
    smc_->save_state(out);
    out.seal();
    checkpoint_checksum_ = out.last_seal();
  });
  ++seq_;
  if (rewrote_log) {
    std::error_code ec;
    fs::rename(log + ".next", log, ec);
    if (ec) throw IoError("stream: cannot rename '" + log + ".next' to '" + log + "': " + ec.message());
  }
  write_history_and_posterior(source, lines_consumed);
}

void WimStream::write_history_and_posterior(const std::string& source, std::size_t lines_consumed) {
  const fleet::PosteriorCloud cloud = smc_->cloud();
  const HistoryRowsInput row{.seq = seq_, .source = source, .lines_consumed = lines_consumed,
                             .ess = smc_->sampler().ess(), .checkpoint_checksum = checkpoint_checksum_};
  history_->append(history_rows(cloud, site_, options_.history_prediction, row));
  io::write_posterior_file(path_in(options_.state_dir, "posterior.json"), cloud, fleet::summarise_cloud(cloud),
                           fleet::summarise_psi(cloud));
}

void WimStream::report() const {
  if (smc_->trucks_seen() == 0) return;
  const auto prediction = predict::predict_ssr(smc_->cloud(), site_, {}, options_.prediction);
  reports_ << "# SSR prediction after " << smc_->trucks_seen() << " trucks\n";
  predict::write_prediction_csv(reports_, prediction);
  reports_.flush();
}

StreamCounts WimStream::run(std::istream& in, const std::string& source, const std::atomic<bool>& stop) {
  io::WimLogReader reader(in, source, site_.options().unsprung_mass_kg);
  if (reader.sensors() != site_.sensors()) {
    throw DataError(source, 1, "if_" + std::to_string(reader.sensors()),
                    "the input has " + std::to_string(reader.sensors()) + " sensors but the site has " +
                        std::to_string(site_.sensors()));
  }
  reader.set_follow(options_.follow);
  const bool same_source = resumed_ && source == checkpoint_source_;
  const std::unordered_set<std::string> absorbed_before(smc_->truck_ids().begin(), smc_->truck_ids().end());

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
  for (;;) {
    if (stop.load()) break;
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
    if (absorbed_before.count(record.truck_id)) {
      ++counts.skipped;
      continue;
    }
    const auto& stage = smc_->absorb(record);
    ++counts.absorbed;
    save_state(source, line);
    if (progress_) {
      *progress_ << "stream: truck " << smc_->trucks_seen() << " " << record.truck_id << " (line " << line << "): "
                 << stage.steps.size() << " steps, ESS " << std::fixed << std::setprecision(0) << smc_->sampler().ess()
                 << ", " << std::setprecision(3) << stage.wall_time_s << " s";
      const std::string note = smc_->note();
      *progress_ << (note.empty() ? "" : "; ") << note << "\n";
      progress_->unsetf(std::ios::floatfield);
    }
    if (options_.report_every > 0 && smc_->trucks_seen() % options_.report_every == 0) report();
  }
  report();
  counts.total_absorbed = smc_->trucks_seen();
  return counts;
}

}  // namespace ssrfleet::stream
