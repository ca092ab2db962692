#include "util/spill_strings.hpp"

#include <vector>

namespace ssrfleet::util {
namespace {

// FNV-1a 64, then a finaliser (splitmix64's) so the low bits that pick a slot mix every byte.
std::uint64_t hash_of(std::string_view s) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (const char c : s) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebULL;
  return h ^ (h >> 31);
}

constexpr std::size_t kFirstCapacity = 1024;  // slots; a power of 2, kept at most half full

}  // namespace

void SpillStringList::push_back(std::string_view s) {
  const std::size_t before = chars_.size();
  chars_.append(s.data(), s.size());
  try {
    ends_.push_back(before + s.size());
  } catch (...) {
    chars_.truncate(before);
    throw;
  }
}

SpillStringSet::SpillStringSet(const std::string& directory) : spilled_(!directory.empty()), directory_(directory) {
  if (!spilled_) return;
  strings_ = SpillStringList(directory);
  table_ = SpillFile(directory);
  const std::vector<Slot> empty(kFirstCapacity);
  table_.append(empty.data(), empty.size() * sizeof(Slot));
  capacity_ = kFirstCapacity;
}

std::size_t SpillStringSet::find(std::string_view s, std::uint64_t hash) const {
  const Slot* slot = slots();
  for (std::size_t i = hash & (capacity_ - 1);; i = (i + 1) & (capacity_ - 1)) {
    if (slot[i].string == 0) return i;
    if (slot[i].hash == hash && strings_[slot[i].string - 1] == s) return i;
  }
}

bool SpillStringSet::contains(std::string_view s) const {
  if (!spilled_) return memory_.count(std::string(s)) > 0;
  return slots()[find(s, hash_of(s))].string != 0;
}

bool SpillStringSet::insert(std::string_view s) {
  if (!spilled_) return memory_.insert(std::string(s)).second;
  const std::uint64_t h = hash_of(s);
  if (slots()[find(s, h)].string != 0) return false;
  if (2 * (count_ + 1) > capacity_) grow();
  const std::size_t at = find(s, h);
  strings_.push_back(s);
  const Slot slot{h, strings_.size()};
  table_.write_at(at * sizeof(Slot), &slot, sizeof slot);  // the string is in first: a failed write leaves it unreferenced
  ++count_;
  return true;
}

void SpillStringSet::grow() {
  // A table of twice the slots, filled from the old one's, replaces it.
  const std::size_t capacity = 2 * capacity_;
  std::vector<Slot> fresh(capacity);
  const Slot* old = slots();
  for (std::size_t i = 0; i < capacity_; ++i) {
    if (old[i].string == 0) continue;
    std::size_t j = old[i].hash & (capacity - 1);
    while (fresh[j].string != 0) j = (j + 1) & (capacity - 1);
    fresh[j] = old[i];
  }
  SpillFile table(directory_);
  table.append(fresh.data(), fresh.size() * sizeof(Slot));
  table_ = std::move(table);
  capacity_ = capacity;
}

}  // namespace ssrfleet::util
