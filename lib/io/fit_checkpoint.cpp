#include "io/fit_checkpoint.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "io/atomic_file.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

namespace {
namespace fs = std::filesystem;
constexpr std::uint64_t kMagic = 0x4b54494646525353ULL;  // "SSRFFITK"
constexpr std::uint32_t kVersion = 1;
// The fixed-size state is a few bytes per particle (about 80 kB at 1,024).
constexpr std::size_t kMaxStateBytes = std::size_t{1} << 30;

void write_checkpoint(std::ostream& os, const fleet::OnlineFit& fit) {
  BinaryWriter out(os);
  out.value(kMagic);
  out.value(kVersion);
  std::ostringstream state;
  BinaryWriter s(state);
  fit.save_state(s);
  out.text(state.str());
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

std::string fit_checkpoint_path(const std::string& dir, std::uint64_t seed) {
  return (fs::path(dir) / ("fit." + std::to_string(seed) + ".ckpt")).string();
}

void write_fit_checkpoint(const std::string& path, const fleet::OnlineFit& fit, const util::Ranks& ranks) {
  if (ranks.rank() == 0) {
    write_file_atomically(path, [&](std::ostream& os) { write_checkpoint(os, fit); });
  } else {
    NullBuffer none;
    std::ostream os(&none);
    write_checkpoint(os, fit);
  }
}

std::size_t read_fit_checkpoint(const std::string& path, fleet::OnlineFit& fit,
                                const std::vector<records::WimRecord>& records) {
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
  std::istringstream state_bytes(in.text("state", kMaxStateBytes));
  in.check_seal("checkpoint head");
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
  const auto& ids = fit.truck_ids();
  for (std::size_t i = 0; i < n && i < ids.size(); ++i) {
    if (ids[i] != records[i].truck_id) refuse(i, "id '" + ids[i] + "' against the log's '" + records[i].truck_id + "'");
  }
  if (const fleet::MarginalSmc* m = fit.marginal()) {
    const auto& t = m->target();
    for (std::size_t i = 0; i < n; ++i) {
      const auto& r = records[i];
      if (t.truck_sites()[i] != r.site || t.speed_mps()[i] != r.speed_mps || t.sprung_mass_kg()[i] != r.sprung_mass_kg ||
          t.observed_if()[i] != r.impact_factor) {
        refuse(i, "its data differ from the log's");
      }
    }
  }
  return n;
}

}  // namespace ssrfleet::io
