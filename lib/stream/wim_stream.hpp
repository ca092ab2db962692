// Online operation (docs/streaming.md): WIM records arrive one at a time,
// each good one is absorbed into the fleet posterior as one SMC stage, and the state directory
// always holds a consistent posterior and a checkpoint to resume from.
//
// State directory:
//   checkpoint.bin   the stream's bookkeeping (with the checkpoint's sequence number), then each
//                    class's core state; rewritten atomically after every absorbed truck. Its size
//                    does not grow with the trucks absorbed on the default (marginal) core: their
//                    records are in the truck logs
//   trucks.bin       the marginal core's truck records (id, data, fit, table) after a header naming
//                    the tables' generation; with vehicle classes one log per class,
//                    trucks.LABEL.bin (stream/class_cores.hpp). Appended and synced before the
//                    checkpoint that counts them: a crash between the append and the checkpoint
//                    leaves a tail that the resume cuts off. After a table rebuild (a few times per
//                    doubling of the early stream, none later) the whole log is written to
//                    trucks.bin.next, the checkpoint naming the new generation follows, and only then
//                    does the rename replace trucks.bin, so the log on disk always matches the
//                    checkpoint (a resume finishes or discards a rename that a crash or a full disk
//                    interrupted)
//   history.sqlite   every checkpoint's report (hyperparameter summaries, an SSR prediction), in
//                    SQLite (io/history_db.hpp), written after the checkpoint's rename and naming its
//                    sequence number and checksum; a resume adds the one row set a failure between
//                    the two can leave missing, and refuses a history that disagrees
//   posterior.json   the posterior file `predict --posterior DIR` reads (a posterior per class when
//                    the input has a class column); rewritten atomically after every checkpoint. Its
//                    size stops growing at MarginalSmc::kPredictionPool trucks (the speeds and
//                    masses predictions draw from), so its cost per truck is flat
//   rejects.csv      every rejected record verbatim, each after a '# line N: reason' comment, under
//                    a copy of the input's header, so it is itself a WIM log to fix and replay
//   lock             flock(2)ed by the running stream, holding its process id (state_lock.hpp):
//                    a second stream on the same state exits at once with status 75
//
// A write that fails (a full disk, a read-only directory) is an IoError that ends the run; every
// file above is then as the last good checkpoint left it, or ahead of it in a way the resume
// repairs, so the stream resumes exactly once the disk is writable again.
//
// Resuming: with checkpoint.bin present, the stream restores it, cuts rejects.csv back to what it
// held at that checkpoint, skips the input's lines up to the checkpoint (same input) and any
// record whose truck_id was already absorbed, and goes on. The result is bit-identical to an
// uninterrupted run with the same seed; no accepted record is absorbed twice or lost.
#pragma once

#include <atomic>
#include <cstdint>
#include <istream>
#include <ostream>
#include <string>

#include <memory>
#include <set>

#include "fleet/online_fit.hpp"
#include "io/history_db.hpp"
#include "io/wim_log.hpp"
#include "predict/ssr_prediction.hpp"
#include "site/site.hpp"
#include "stream/class_cores.hpp"
#include "stream/state_lock.hpp"
#include "util/binary_io.hpp"

namespace ssrfleet::stream {

struct StreamOptions {
  std::string state_dir;
  int report_every = 0;         // print the SSR table every N absorbed trucks (0 = only at the end)
  bool follow = false;          // at end of input, wait for more (like tail -f) until stopped
  double follow_poll_s = 0.25;  // how often to look for more input in follow mode
  // The core (marginal by default) and its sampler options; fit.extension: the model's effects
  // (model_spec.hpp), recorded in the state by name.
  fleet::OnlineFitOptions fit;
  predict::PredictionOptions prediction;
  // Vehicle classes: when not empty, the only classes a new state accepts (a record of another is
  // quarantined, field `class`); a resumed state keeps the list it was made with (another list is
  // refused). Empty: a new label starts a new class. limits.fhwa_classes: labels must be 1..13.
  std::set<std::string> classes;
  io::WimLimits limits;
  // The prediction each checkpoint's history row set holds: lighter than a report's, since it runs
  // after every truck (about 2,000 passes per class; history_rows.hpp).
  predict::PredictionOptions history_prediction{.theta_draws = 50, .trucks_per_draw = 40};
  // The marginal core keeps its truck tables, the trucks' data and ids in unnamed files in the state
  // directory, paged by the kernel (model/table_store.hpp), so the stream's private memory stays
  // flat; true keeps them in the process's memory (about 5 kB a truck on AS1). The same bits.
  bool tables_in_memory = false;
};

struct StreamCounts {
  long absorbed = 0;  // this run
  long rejected = 0;  // this run
  long skipped = 0;   // already absorbed before a resume
  long total_absorbed = 0;  // in the posterior, over all runs
};

class WimStream {
 public:
  // Creates the state directory if needed and resumes from its checkpoint if one is there.
  // progress: one line per truck and per rejected record (nullptr = silent); reports: the SSR
  // tables (stdout in the command).
  WimStream(const site::Site& site, StreamOptions options, std::ostream* progress, std::ostream& reports)
      : WimStream(std::vector<StreamSite>{{"", &site, {}}}, std::move(options), progress, reports) {}
  // A stream of several sites, one fleet (docs/sites.md): its input's `site` column names each
  // record's site (io::WimLogReader::set_sites); the sites must outlive the stream. The history's
  // predictions and the --report-every tables are at the first site; posterior.json holds every site
  // (predict --posterior DIR --sites M --site NAME predicts any of them).
  struct StreamSite {
    std::string name;  // the manifest's name ("" for a stream of one site)
    const site::Site* site = nullptr;
    // The site's sensor gains (the manifest's "calibration"; empty: every gain 1), divided out of
    // each of its records before the fleet sees it. Part of the site's identity in the state: a
    // resume with other gains is refused, since the absorbed trucks were corrected with these.
    Eigen::VectorXd calibration;
  };
  WimStream(std::vector<StreamSite> sites, StreamOptions options, std::ostream* progress, std::ostream& reports);

  bool resumed() const { return resumed_; }
  // What the user should know about the posterior's quality (fleet::OnlineFit::warning), "" if nothing.
  std::string warning() const { return cores_.warning(); }

  // Reads records from `in` until its end (or, following, until `stop` is set). `source` names
  // the input in messages and in the checkpoint (a resume skips by line only on the same source).
  StreamCounts run(std::istream& in, const std::string& source, const std::atomic<bool>& stop);

 private:
  std::unique_ptr<StateLock> lock_;  // held for the stream's life (state_lock.hpp)
  // The model's spec as the state records it: "base" or the extension's name.
  std::string model_text() const {
    return options_.fit.extension != nullptr ? options_.fit.extension->name() : "base";
  }
  void restore_checkpoint(const std::string& checkpoint);
  void open_history();
  void save_state(const std::string& source, std::size_t lines_consumed);
  void write_history_and_posterior(const std::string& source, std::size_t lines_consumed);
  void write_posterior(const fleet::ClassPosteriors& classes);
  void report() const;

  std::vector<const site::Site*> site_pointers() const;
  std::vector<std::string> site_names() const;
  // Each site as the state names it: its name, and its calibration if it has one.
  std::vector<std::string> site_identities() const;
  // What posterior.json records of the sites' calibrations (empty when no site has one).
  std::vector<fleet::SiteCalibration> calibration() const;
  // The cores' posteriors with the sites' names (a stream of several sites).
  fleet::ClassPosteriors posteriors() const;

  std::vector<StreamSite> sites_;
  const site::Site& site_;  // the first: where the history and the reports predict
  StreamOptions options_;
  std::ostream* progress_;
  std::ostream& reports_;
  ClassCores cores_;  // a fleet posterior per vehicle class (one, unlabelled, without a class column)
  bool resumed_ = false;
  // Bookkeeping restored from the checkpoint.
  std::string checkpoint_source_;
  std::size_t checkpoint_lines_ = 0;
  std::uint64_t rejects_bytes_ = 0;
  std::uint64_t seq_ = 0;                  // checkpoints written into this state, over all runs
  std::uint64_t checkpoint_checksum_ = 0;  // the seal of checkpoint number seq_
  std::uint64_t posterior_seq_ = 0;        // the checkpoint posterior.json was last written at (this run)
  std::unique_ptr<io::HistoryDb> history_;
};

}  // namespace ssrfleet::stream
