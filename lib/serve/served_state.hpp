// One stream state as `serve` follows it: its history reader, its quarantine and its lock, and the
// newest snapshot, refreshed by the server's poll (every 0.25 s by default) only when the history
// has a new checkpoint. Requests read the snapshot the poll last made (a shared pointer, never
// changed once made), so a page's summary, SSR and hyperparameters always come from one checkpoint
// and a thousand requests cost the database nothing.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "serve/rejects_tail.hpp"
#include "serve/state_reader.hpp"
#include "serve/stream_status.hpp"
#include "site/site.hpp"

namespace ssrfleet::serve {

struct ServedSite {
  std::string name;  // the manifest's name ("" for a stream of one site)
  const site::Site* site = nullptr;
};

struct StateConfig {
  std::string name;  // how the API and the page name it
  std::string dir;
  // Where the stream's posterior applies: its one site, or a joint stream's sites in the
  // manifest's order (the history's predictions are at the first).
  std::vector<ServedSite> sites;
};

class ServedState {
 public:
  explicit ServedState(StateConfig config);

  // Polls the state: a new checkpoint is read whole, the quarantine and the lock looked at again.
  void refresh();

  struct View {
    std::shared_ptr<const Snapshot> snapshot;  // null before the first checkpoint
    LockState lock;
    std::string error;  // why the last read failed ("" if it did not)
  };
  View view() const;

  // Answers that cost a database query (the history), kept per checkpoint: every page asks the
  // same question after each checkpoint, and only the first asker pays for it. Keyed by the query
  // string; an answer of an older checkpoint is never returned, and at most 16 are kept.
  std::shared_ptr<const std::string> cached_answer(const std::string& key, std::uint64_t seq) const;
  void store_answer(const std::string& key, std::uint64_t seq, std::shared_ptr<const std::string> body);

  StateReader& reader() { return reader_; }
  const RejectsTail& rejects() const { return rejects_; }
  const StateConfig& config() const { return config_; }

 private:
  StateConfig config_;
  StateReader reader_;
  RejectsTail rejects_;
  mutable std::mutex mutex_;
  std::shared_ptr<const Snapshot> snapshot_;
  LockState lock_;
  std::string error_;
  std::map<std::string, std::pair<std::uint64_t, std::shared_ptr<const std::string>>> answers_;
};

}  // namespace ssrfleet::serve
