// A stream state's fleet posteriors, one per vehicle class, each an
// independent fleet::OnlineFit seeded from the stream's seed and its label
// (fleet::class_seed). An unlabelled input is one class with the empty label, whose core is
// exactly the single core of a state before classes: its seed, its truck log trucks.bin.
//
// Checkpoint part (inside checkpoint.bin, after the stream's bookkeeping): the fixed class list,
// the class count, then per class (sorted by label) its label, its truck log's bookkeeping and the
// core's state. On the marginal core each class appends its trucks to its own log, trucks.bin for
// the unlabelled class and trucks.LABEL.bin for a labelled one: a sealed header naming the tables'
// generation, then the records, each sealed by the core. After a table rebuild the class's whole
// log goes to LOG.next, and commit_logs() renames it over LOG once the checkpoint naming its
// generation is in place (restore() finishes or drops a rename that never happened).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "fleet/online_fit.hpp"
#include "fleet/vehicle_classes.hpp"
#include "site/site.hpp"
#include "util/binary_io.hpp"
#include "util/spill_strings.hpp"

namespace ssrfleet::stream {

class ClassCores {
 public:
  // sites: the stream's sites (one, or a manifest's: fleet/joint_sites.hpp), outliving this.
  ClassCores(std::vector<const site::Site*> sites, fleet::OnlineFitOptions options, std::string state_dir);

  // The classes fixed when the state was made (empty = a new label starts a new class).
  const std::set<std::string>& fixed() const { return fixed_; }
  void set_fixed(std::set<std::string> classes) { fixed_ = std::move(classes); }

  bool empty() const { return cores_.empty(); }
  // True when the state holds labelled classes; false when unlabelled or empty.
  bool labelled() const { return !cores_.empty() && !cores_.begin()->first.empty(); }
  // The core of `label`, made on first use with the seed fleet::class_seed(seed, label).
  fleet::OnlineFit& core(const std::string& label);
  long trucks_seen() const;
  // Every class's absorbed truck ids, as a set in spill files in `spill_directory` ("": in memory).
  util::SpillStringSet truck_ids(const std::string& spill_directory) const;
  std::string labels() const;  // "A, B" for messages
  std::string warning() const;  // every class's warning, prefixed with its label when labelled
  fleet::ClassPosteriors posteriors() const;

  // Before the checkpoint: appends each class's new trucks to its log, or writes the whole log to
  // LOG.next after a table rebuild.
  void write_logs();
  // The checkpoint part (no file is touched).
  void save(BinaryWriter& out) const;
  // After the checkpoint's rename: each LOG.next that write_logs() made replaces its LOG.
  void commit_logs();
  // Reads the checkpoint part: each class's core restored from it and its truck log (a tail
  // beyond the checkpoint's length cut off). `split`: the state was written by a splitting core.
  void restore(BinaryReader& in, bool split);
  // After the checkpoint's seal was checked: each class's truck log holds the trucks its
  // checkpoint counts (DataError naming the checkpoint otherwise).
  void check_counts(const BinaryReader& in) const;
  bool splits_state() const;

 private:
  struct Core {
    std::unique_ptr<fleet::OnlineFit> fit;
    std::uint64_t trucks_written = 0, trucks_bytes = 0;
    int trucks_generation = -1;
    bool log_rewritten = false;  // LOG.next waits for commit_logs()
  };
  std::string truck_log(const std::string& label) const;
  Core& make(const std::string& label);

  std::vector<const site::Site*> sites_;
  fleet::OnlineFitOptions options_;
  std::string state_dir_;
  std::set<std::string> fixed_;
  std::map<std::string, Core> cores_;
};

}  // namespace ssrfleet::stream
