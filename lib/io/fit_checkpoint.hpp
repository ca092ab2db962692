// The checkpoint of `fit --checkpoint DIR` (docs/inference.md): a long offline fit, on
// one process or on MPI ranks, that stops (a lost rank, a killed job, a full disk) resumes where
// its last checkpoint left it, with the bits of a run that never stopped, on any number of ranks.
// One file per class's fit, DIR/fit.SEED.ckpt (SEED: the class's own seed), replaced atomically:
//   a sealed head: magic "SSRFFITK", format version, the core's fixed-size state (OnlineFit::
//   save_state: particles, weights, settings, the trucks' count; the site and seed it belongs to);
//   then each truck's record (id, data, fit, table), sealed one by one (OnlineFit::save_trucks);
//   nothing after the last.
// On several ranks every rank takes part (each truck's record comes from the rank holding its
// table) and rank 0 writes the file; every rank reads the whole file on a resume and keeps its own
// trucks' tables, so the rank count may differ from the run that wrote it (the file is the one
// process would write). The ranks must see DIR on a shared file system.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fleet/online_fit.hpp"
#include "records/wim_record.hpp"
#include "util/ranks.hpp"

namespace ssrfleet::io {

// DIR/fit.SEED.KEY.ckpt: SEED the class's seed, KEY a hash of the sites' fingerprint, so fits of
// other sites (or another manifest) in the same directory keep their own files.
std::string fit_checkpoint_path(const std::string& dir, std::uint64_t seed, const std::string& sites_fingerprint);

// What must match for a resume besides the sites and the seed (which the state checks itself): the
// options that change the run from a given state, as text (e.g. "particles=1024 cess=0.5 ...").
// A checkpoint made with others is refused, naming both.

// Collective over `ranks` (every rank calls it; rank 0 writes). It first checks that every rank's
// particles are the same bits as rank 0's (NumericalError otherwise: ranks on different CPUs or
// builds). IoError naming the file if it cannot be written (the previous checkpoint stays whole),
// thrown on rank 0 alone and only after its part in the collectives, so the ranks stay in step.
void write_fit_checkpoint(const std::string& path, const fleet::OnlineFit& fit, const util::Ranks& ranks,
                          const std::string& options);

// If `path` exists: restores `fit` (new, of the same sites and seed) from it and returns the trucks it
// holds, after checking its options and its trucks against the records' first ones (id, site,
// speed, mass and impact factors; a DataError naming the file and the truck if the log changed
// since). 0 if there is no file.
std::size_t read_fit_checkpoint(const std::string& path, fleet::OnlineFit& fit,
                                const std::vector<records::WimRecord>& records, const std::string& options);

// Collective: throws the same DataError on every rank unless every rank read the same records and
// resumed from the same truck (a log appended to, or a checkpoint written, while the ranks started
// would otherwise split the ranks' work into different runs).
void check_ranks_agree(const util::Ranks& ranks, const std::vector<records::WimRecord>& records, std::size_t resumed);

// When a fit of `trucks` trucks writes its next checkpoint: after the last truck, once `every_s`
// seconds of fitting have passed since the last one, and every `every_trucks` trucks (0: by time
// only). The ranks must write together, so rank 0's clock decides for all of them.
class CheckpointClock {
 public:
  CheckpointClock(const util::Ranks& ranks, std::size_t trucks, double every_s, long every_trucks);
  // Collective: whether a checkpoint is due after truck t (0-based); the same answer on every rank.
  bool due(std::size_t t);
  // Counts the seconds again from now (call it after each checkpoint, written or not).
  void restart();

 private:
  using Clock = std::chrono::steady_clock;
  const util::Ranks& ranks_;
  std::size_t trucks_;
  double every_s_;
  long every_trucks_;
  Clock::time_point last_;
};

}  // namespace ssrfleet::io
