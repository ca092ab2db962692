#include "stream/wim_stream.hpp"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <thread>
#include <unordered_set>

#include "fleet/posterior_summary.hpp"
#include "io/atomic_file.hpp"
#include "io/posterior_json.hpp"
#include "io/wim_log.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

namespace ssrfleet::stream {

namespace fs = std::filesystem;

namespace {
std::string path_in(const std::string& dir, const char* name) { return (fs::path(dir) / name).string(); }
}  // namespace

WimStream::WimStream(const site::Site& site, StreamOptions options, std::ostream* progress, std::ostream& reports)
    : site_(site), options_(std::move(options)), progress_(progress), reports_(reports), smc_(site, options_.smc) {
  if (options_.state_dir.empty()) throw UsageError("stream: a state directory is required (--state DIR)");
  if (options_.report_every < 0) throw UsageError("stream: --report-every must be >= 0");
  std::error_code ec;
  fs::create_directories(options_.state_dir, ec);
  if (ec || !fs::is_directory(options_.state_dir)) {
    throw IoError("stream: cannot create the state directory '" + options_.state_dir + "': " + ec.message());
  }
  const std::string checkpoint = path_in(options_.state_dir, "checkpoint.bin");
  if (!fs::exists(checkpoint)) return;
  std::ifstream in(checkpoint, std::ios::binary);
  if (!in) throw IoError("stream: cannot read '" + checkpoint + "'");
  BinaryReader reader(in, checkpoint);
  smc_.restore(reader);
  checkpoint_source_ = reader.text("source");
  checkpoint_lines_ = reader.value<std::uint64_t>("lines_consumed");
  rejects_bytes_ = reader.value<std::uint64_t>("rejects_bytes");
  resumed_ = true;
  // Records rejected after the checkpoint will be read and rejected again: cut them off here so
  // rejects.csv lists each bad record once.
  const std::string rejects = path_in(options_.state_dir, "rejects.csv");
  if (fs::exists(rejects) && fs::file_size(rejects) > rejects_bytes_) fs::resize_file(rejects, rejects_bytes_);
  if (progress_) {
    *progress_ << "stream: resumed from " << checkpoint << " with " << smc_.trucks_seen() << " trucks absorbed\n";
  }
}

void WimStream::save_state(const std::string& source, std::size_t lines_consumed) const {
  io::write_file_atomically(path_in(options_.state_dir, "checkpoint.bin"), [&](std::ostream& os) {
    BinaryWriter out(os);
    smc_.save(out);
    out.text(source);
    out.value<std::uint64_t>(lines_consumed);
    out.value<std::uint64_t>(rejects_bytes_);
  });
  const fleet::PosteriorCloud cloud = smc_.cloud();
  io::write_posterior_file(path_in(options_.state_dir, "posterior.json"), cloud, fleet::summarise_cloud(cloud));
}

void WimStream::report() const {
  if (smc_.trucks_seen() == 0) return;
  const auto prediction = predict::predict_ssr(smc_.cloud(), site_, {}, options_.prediction);
  reports_ << "# SSR prediction after " << smc_.trucks_seen() << " trucks\n";
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
  const std::unordered_set<std::string> absorbed_before(smc_.truck_ids().begin(), smc_.truck_ids().end());

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
    const auto& stage = smc_.absorb(record);
    ++counts.absorbed;
    save_state(source, line);
    if (progress_) {
      *progress_ << "stream: truck " << smc_.trucks_seen() << " " << record.truck_id << " (line " << line << "): "
                 << stage.steps.size() << " steps, ESS " << std::fixed << std::setprecision(0) << smc_.sampler().ess()
                 << ", " << std::setprecision(3) << stage.wall_time_s << " s\n";
      progress_->unsetf(std::ios::floatfield);
    }
    if (options_.report_every > 0 && smc_.trucks_seen() % options_.report_every == 0) report();
  }
  report();
  counts.total_absorbed = smc_.trucks_seen();
  return counts;
}

}  // namespace ssrfleet::stream
