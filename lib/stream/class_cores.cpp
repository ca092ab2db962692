#include "stream/class_cores.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "io/atomic_file.hpp"
#include "util/errors.hpp"

namespace ssrfleet::stream {

namespace fs = std::filesystem;

namespace {
constexpr std::uint64_t kTruckLogMagic = 0x534b525446525353ULL;  // "SSRFTRKS"

// A truck log's header: which generation of tables its records hold.
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

ClassCores::ClassCores(std::vector<const site::Site*> sites, fleet::OnlineFitOptions options, std::string state_dir)
    : sites_(std::move(sites)), options_(std::move(options)), state_dir_(std::move(state_dir)) {}

std::string ClassCores::truck_log(const std::string& label) const {
  return (fs::path(state_dir_) / (label.empty() ? std::string("trucks.bin") : "trucks." + label + ".bin")).string();
}

ClassCores::Core& ClassCores::make(const std::string& label) {
  fleet::OnlineFitOptions o = options_;
  o.sampler().seed = fleet::class_seed(options_.sampler().seed, label);
  auto fit = fleet::make_online_fit(sites_, o);  // before the map holds an entry for it
  Core& c = cores_[label];
  c.fit = std::move(fit);
  return c;
}

fleet::OnlineFit& ClassCores::core(const std::string& label) {
  const auto it = cores_.find(label);
  return it != cores_.end() ? *it->second.fit : *make(label).fit;
}

long ClassCores::trucks_seen() const {
  long n = 0;
  for (const auto& [label, c] : cores_) n += c.fit->trucks_seen();
  return n;
}

util::SpillStringSet ClassCores::truck_ids(const std::string& spill_directory) const {
  util::SpillStringSet ids(spill_directory);
  for (const auto& [label, c] : cores_)
    for (std::size_t i = 0; i < c.fit->truck_id_count(); ++i) ids.insert(c.fit->truck_id(i));
  return ids;
}

std::string ClassCores::labels() const {
  std::string s;
  for (const auto& [label, c] : cores_) s += (s.empty() ? "" : ", ") + label;
  return s;
}

std::string ClassCores::warning() const {
  std::string s;
  for (const auto& [label, c] : cores_) {
    const std::string w = c.fit->warning();
    if (w.empty()) continue;
    s += (s.empty() ? "" : "; ") + (label.empty() ? w : "class " + label + ": " + w);
  }
  return s;
}

fleet::ClassPosteriors ClassCores::posteriors() const {
  fleet::ClassPosteriors out;
  for (const auto& [label, c] : cores_) {
    if (c.fit->trucks_seen() > 0) out.push_back({label, c.fit->cloud()});
  }
  return out;
}

bool ClassCores::splits_state() const {
  return cores_.empty() ? options_.core == fleet::OnlineFitOptions::Core::kMarginal : cores_.begin()->second.fit->splits_state();
}

void ClassCores::write_logs() {
  for (auto& entry : cores_) {
    // Not a structured binding: clang 14 (the fuzz build's) cannot capture one in the lambda below.
    const std::string& label = entry.first;
    auto& c = entry.second;
    if (!c.fit->splits_state()) continue;
    const std::string log = truck_log(label);
    const auto n = static_cast<std::uint64_t>(c.fit->trucks_seen());
    if (c.fit->table_generation() != c.trucks_generation || c.trucks_written > n) {
      // New tables: a whole new log beside the old one, which stays until the checkpoint names it.
      c.trucks_generation = c.fit->table_generation();
      io::write_file_atomically(log + ".next", [&](std::ostream& os) {
        BinaryWriter w(os);
        write_truck_log_header(w, c.trucks_generation);
        c.fit->save_trucks(w, 0, n);
      });
      c.trucks_bytes = fs::file_size(log + ".next");
      c.log_rewritten = true;
    } else if (n > c.trucks_written) {
      std::ostringstream records;
      BinaryWriter w(records);
      c.fit->save_trucks(w, c.trucks_written, n);
      io::append_file_synced(log, records.str());
      c.trucks_bytes += records.str().size();
    }
    c.trucks_written = n;
  }
}

void ClassCores::save(BinaryWriter& out) const {
  out.value<std::uint64_t>(fixed_.size());
  for (const auto& label : fixed_) out.text(label);
  out.value<std::uint64_t>(cores_.size());
  for (const auto& [label, c] : cores_) {
    out.text(label);
    out.value<std::uint64_t>(c.trucks_written);
    out.value<std::uint64_t>(c.trucks_bytes);
    out.value<std::int32_t>(c.trucks_generation);
    c.fit->save_state(out);
  }
}

void ClassCores::commit_logs() {
  for (auto& [label, c] : cores_) {
    if (!c.log_rewritten) continue;
    const std::string log = truck_log(label);
    std::error_code ec;
    fs::rename(log + ".next", log, ec);
    if (ec) throw IoError("stream: cannot rename '" + log + ".next' to '" + log + "': " + ec.message());
    c.log_rewritten = false;
  }
}

void ClassCores::restore(BinaryReader& in, bool split) {
  cores_.clear();
  fixed_.clear();
  const auto n_fixed = in.value<std::uint64_t>("fixed_classes");
  if (n_fixed > 100000) in.fail("fixed_classes", "implausible class count");
  for (std::uint64_t k = 0; k < n_fixed; ++k) fixed_.insert(in.text("fixed_class"));
  const auto n_classes = in.value<std::uint64_t>("classes");
  if (n_classes > 100000) in.fail("classes", "implausible class count");
  for (std::uint64_t k = 0; k < n_classes; ++k) {
    const std::string label = in.text("class");
    Core& c = make(label);
    c.trucks_written = in.value<std::uint64_t>("trucks_written");
    c.trucks_bytes = in.value<std::uint64_t>("trucks_bytes");
    c.trucks_generation = in.value<std::int32_t>("trucks_generation");
    if (split != c.fit->splits_state()) {
      in.fail("core", std::string("the state was written by the ") + (split ? "marginal" : "latent") +
                          " core; resume it with the model it was written with (the model decides the core)");
    }
    if (!split) {
      c.fit->restore(in);
      continue;
    }
    const std::string log = truck_log(label);
    if (fs::exists(log + ".next")) {
      // A rewrite that stopped before its rename: finish it if the checkpoint already names it,
      // drop it if the checkpoint never got that far.
      if (truck_log_generation(log + ".next") == c.trucks_generation) {
        fs::rename(log + ".next", log);
      } else {
        fs::remove(log + ".next");
      }
    }
    // A crash between appending to a truck log and the checkpoint leaves a tail: cut it off.
    if (!fs::exists(log) || fs::file_size(log) < c.trucks_bytes) {
      in.fail("trucks_bytes", "'" + log + "' is missing or shorter than the checkpoint says (" +
                                  std::to_string(c.trucks_bytes) + " bytes)");
    }
    if (fs::file_size(log) > c.trucks_bytes) fs::resize_file(log, c.trucks_bytes);
    std::ifstream trucks_in(log, std::ios::binary);
    if (!trucks_in) throw IoError("stream: cannot read '" + log + "'");
    BinaryReader trucks(trucks_in, log);
    const std::int32_t generation = read_truck_log_header(trucks);
    if (generation != c.trucks_generation) {
      trucks.fail("generation", "the truck log holds tables of generation " + std::to_string(generation) +
                                    ", the checkpoint names generation " + std::to_string(c.trucks_generation));
    }
    c.fit->restore_split(in, trucks);
  }
}

void ClassCores::check_counts(const BinaryReader& in) const {
  for (const auto& [label, c] : cores_) {
    if (c.fit->splits_state() && static_cast<std::uint64_t>(c.fit->trucks_seen()) != c.trucks_written) {
      in.fail("trucks_written", "the checkpoint and the truck log '" + truck_log(label) + "' disagree on the truck count");
    }
  }
}

}  // namespace ssrfleet::stream
