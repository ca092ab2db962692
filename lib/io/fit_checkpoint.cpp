#include "io/fit_checkpoint.hpp"

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "io/atomic_file.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

namespace {
namespace fs = std::filesystem;
constexpr std::uint64_t kMagic = 0x4b54494646525353ULL;  // "SSRFFITK"
// Version 2 adds the options to the head (magic, version, options, state; sealed); version 1 (the
// first build with checkpoints, for a few commits) had no options and is refused by its version.
constexpr std::uint32_t kVersion = 2;
// The fixed-size state is a few bytes per particle (about 80 kB at 1,024).
constexpr std::size_t kMaxStateBytes = std::size_t{1} << 30;

std::uint64_t hash_of(const std::string& bytes) { return detail::fnv1a(detail::kFnvOffset, bytes.data(), bytes.size()); }

// Collective: does every rank hold rank 0's `value`? (The same answer on every rank.)
bool all_ranks_hold(const util::Ranks& ranks, std::uint64_t value) {
  std::uint64_t root = value;
  ranks.broadcast(&root, sizeof root, 0);
  util::ExactSum differing;
  differing.add(root == value ? 0.0 : 1.0);
  ranks.sum(&differing, 1);
  return differing.value() == 0.0;
}

void write_checkpoint(std::ostream& os, const fleet::OnlineFit& fit, const std::string& state,
                      const std::string& options) {
  BinaryWriter out(os);
  out.value(kMagic);
  out.value(kVersion);
  out.text(options);
  out.text(state);
  out.seal();
  fit.save_trucks(out, 0, static_cast<std::size_t>(fit.trucks_seen()));
}

// A stream that keeps nothing: what the ranks other than 0 "write".
class NullBuffer final : public std::streambuf {
 protected:
  int_type overflow(int_type c) override { return traits_type::not_eof(c); }
  std::streamsize xsputn(const char*, std::streamsize n) override { return n; }
};
}  // namespace

std::string fit_checkpoint_path(const std::string& dir, std::uint64_t seed, const std::string& sites_fingerprint) {
  std::ostringstream key;
  key << std::hex << std::setw(16) << std::setfill('0') << hash_of(sites_fingerprint);
  return (fs::path(dir) / ("fit." + std::to_string(seed) + "." + key.str() + ".ckpt")).string();
}

void write_fit_checkpoint(const std::string& path, const fleet::OnlineFit& fit, const util::Ranks& ranks,
                          const std::string& options) {
  // The fixed-size state, on every rank (its passes are a sum over the ranks): the same bits on
  // every rank, or the ranks have parted (a rank on another CPU whose exp() rounds otherwise would
  // take other decisions, and their collectives would stop matching).
  std::ostringstream state_bytes;
  BinaryWriter s(state_bytes);
  fit.save_state(s);
  const std::string state = state_bytes.str();
  if (!all_ranks_hold(ranks, hash_of(state))) {
    throw NumericalError("the MPI ranks' particles differ at truck " + std::to_string(fit.trucks_seen()) +
                         ": run every rank with the same ssrfleet-mpi binary on CPUs of one kind");
  }
  NullBuffer none;
  std::ostream nowhere(&none);
  if (ranks.rank() != 0) {
    write_checkpoint(nowhere, fit, state, options);
    return;
  }
  bool written = false;
  try {
    write_file_atomically(path, [&](std::ostream& os) {
      written = true;
      write_checkpoint(os, fit, state, options);
    });
  } catch (const IoError&) {
    // The file could not even be opened: take part in the collectives all the same, so the other
    // ranks are not left waiting, then report.
    if (!written) write_checkpoint(nowhere, fit, state, options);
    throw;
  }
}

void check_ranks_agree(const util::Ranks& ranks, const std::vector<records::WimRecord>& records, std::size_t resumed) {
  if (ranks.size() == 1) return;
  std::ostringstream bytes;
  BinaryWriter w(bytes);
  w.value<std::uint64_t>(resumed);
  for (const auto& r : records) {
    w.text(r.truck_id);
    w.value(r.site);
    w.value(r.speed_mps);
    w.value(r.sprung_mass_kg);
    w.matrix(r.impact_factor);
  }
  if (!all_ranks_hold(ranks, hash_of(bytes.str()))) {
    throw DataError("fit", 0, "ranks",
                    "the MPI ranks read different logs or checkpoints (a file changed while they started, or they do not "
                    "see the same files): run again once the files are still");
  }
}

std::size_t read_fit_checkpoint(const std::string& path, fleet::OnlineFit& fit,
                                const std::vector<records::WimRecord>& records, const std::string& options) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return 0;
  std::ifstream file(path, std::ios::binary);
  if (!file) throw IoError("cannot read checkpoint '" + path + "'");
  BinaryReader in(file, path);
  if (in.value<std::uint64_t>("magic") != kMagic) in.fail("magic", "not a checkpoint of ssrfleet fit");
  const auto version = in.value<std::uint32_t>("version");
  if (version != kVersion) {
    in.fail("version", "format version " + std::to_string(version) + ", this build reads " + std::to_string(kVersion) +
                           ": delete the file to fit from the start");
  }
  const std::string made_with = in.text("options", 4096);
  std::istringstream state_bytes(in.text("state", kMaxStateBytes));
  in.check_seal("checkpoint head");
  if (made_with != options) {
    in.fail("options", "made with " + made_with + ", this fit has " + options +
                           ": run with the checkpoint's options, or delete it to fit from the start");
  }
  BinaryReader state(state_bytes, path);
  fit.restore_split(state, in);
  if (file.peek() != std::ifstream::traits_type::eof()) in.fail("end", "bytes after the last truck's record");

  // The trucks it holds must be the log's first ones: a log edited since would give a posterior of
  // neither.
  const auto n = static_cast<std::size_t>(fit.trucks_seen());
  auto refuse = [&](std::size_t i, const std::string& why) {
    throw DataError(path, 0, "truck " + std::to_string(i + 1),
                    why + ": the log is not the one this checkpoint was made from (delete the checkpoint to fit "
                          "from the start)");
  };
  if (n > records.size()) {
    refuse(records.size(), "the checkpoint holds " + std::to_string(n) + " trucks, the log " +
                               std::to_string(records.size()));
  }
  for (std::size_t i = 0; i < n && i < fit.truck_id_count(); ++i) {
    const std::string id = fit.truck_id(i);
    if (id != records[i].truck_id) refuse(i, "id '" + id + "' against the log's '" + records[i].truck_id + "'");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!fit.holds_record(i, records[i])) refuse(i, "its data differ from the log's");
  }
  return n;
}

CheckpointClock::CheckpointClock(const util::Ranks& ranks, std::size_t trucks, double every_s, long every_trucks)
    : ranks_(ranks), trucks_(trucks), every_s_(every_s), every_trucks_(every_trucks), last_(Clock::now()) {}

bool CheckpointClock::due(std::size_t t) {
  char due = 0;
  if (ranks_.rank() == 0) {
    const double s = std::chrono::duration<double>(Clock::now() - last_).count();
    due = t + 1 == trucks_ || s >= every_s_ ||
          (every_trucks_ > 0 && (t + 1) % static_cast<std::size_t>(every_trucks_) == 0);
  }
  ranks_.broadcast(&due, 1, 0);
  return due != 0;
}

void CheckpointClock::restart() { last_ = Clock::now(); }

}  // namespace ssrfleet::io
