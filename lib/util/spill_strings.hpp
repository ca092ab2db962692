// Strings that grow with a stream's trucks (their ids), kept like the rest of its per-truck data:
// in the process's memory, or, given a directory, in spill files there (spill_file.hpp) that the
// kernel pages, so the stream's private memory stays flat.
//   SpillStringList  the ids in arrival order (a checkpoint writes them, a resume reads them)
//   SpillStringSet   the ids seen so far, for an exact duplicate check: an open-addressing table
//                    of 64-bit hashes, each slot pointing at its string, so a hash match is
//                    confirmed on the string itself and a collision can never reject a new id.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <unordered_set>

#include "util/spill_file.hpp"
#include "util/spill_vector.hpp"

namespace ssrfleet::util {

class SpillStringList {
 public:
  SpillStringList() = default;
  explicit SpillStringList(const std::string& directory) : chars_(directory), ends_(directory) {}

  // IoError from a full disk: nothing is appended then.
  void push_back(std::string_view s);
  void clear() {
    ends_.clear();
    chars_.clear();
  }
  std::size_t size() const { return ends_.size(); }
  bool empty() const { return ends_.empty(); }
  // Valid until the next push_back.
  std::string_view operator[](std::size_t i) const {
    const std::uint64_t begin = i == 0 ? 0 : ends_[i - 1];
    return {chars_.data() + begin, static_cast<std::size_t>(ends_[i] - begin)};
  }

 private:
  SpillVector<char> chars_;
  SpillVector<std::uint64_t> ends_;  // one past each string's last char
};

class SpillStringSet {
 public:
  SpillStringSet() = default;
  explicit SpillStringSet(const std::string& directory);

  bool contains(std::string_view s) const;
  // Adds s; false if it was there already. IoError from a full disk (the set is then as it was).
  bool insert(std::string_view s);
  std::size_t size() const { return spilled_ ? count_ : memory_.size(); }
  bool spilled() const { return spilled_; }

 private:
  struct Slot {
    std::uint64_t hash = 0;
    std::uint64_t string = 0;  // 1 + its index in strings_; 0: an empty slot
  };
  // The slot holding s, or the empty slot where it would go.
  std::size_t find(std::string_view s, std::uint64_t hash) const;
  const Slot* slots() const { return reinterpret_cast<const Slot*>(table_.data()); }
  void grow();

  std::unordered_set<std::string> memory_;  // in memory
  bool spilled_ = false;
  std::string directory_;
  SpillStringList strings_;
  SpillFile table_;
  std::size_t capacity_ = 0, count_ = 0;
};

}  // namespace ssrfleet::util
