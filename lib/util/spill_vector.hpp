// An append-only array of trivially copyable values, in the process's memory (a std::vector) or,
// given a directory, in a spill file there (spill_file.hpp: an unnamed file the kernel pages, read
// through a mapping), so that data growing with a stream's trucks leaves its private memory flat.
// Elements are read in place; a pointer or reference into the array is valid until the next append.
#pragma once

#include <cstddef>
#include <string>
#include <type_traits>
#include <vector>

#include "util/spill_file.hpp"

namespace ssrfleet::util {

template <class T>
class SpillVector {
  static_assert(std::is_trivially_copyable_v<T>, "a spill vector copies its elements' bytes");

 public:
  // In memory.
  SpillVector() = default;
  // In an unnamed file in `directory` ("": in memory). IoError if the file cannot be made.
  explicit SpillVector(const std::string& directory) {
    if (!directory.empty()) file_ = SpillFile(directory);
  }

  // IoError on a failed write (a full disk): nothing is appended then.
  void append(const T* values, std::size_t n) {
    if (file_.is_open())
      file_.append(values, n * sizeof(T));
    else
      memory_.insert(memory_.end(), values, values + n);
    size_ += n;
  }
  void push_back(const T& value) { append(&value, 1); }
  // Forgets the elements from `n` on (a no-op if there are fewer).
  void truncate(std::size_t n) {
    if (n >= size_) return;
    if (file_.is_open())
      file_.shrink_to(n * sizeof(T));
    else
      memory_.resize(n);
    size_ = n;
  }
  void clear() { truncate(0); }

  // The file holds nothing but T's from a page-aligned mapping, so every element is aligned.
  const T* data() const { return file_.is_open() ? reinterpret_cast<const T*>(file_.data()) : memory_.data(); }
  const T& operator[](std::size_t i) const { return data()[i]; }
  const T& back() const { return data()[size_ - 1]; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

  bool spilled() const { return file_.is_open(); }
  const std::string& directory() const { return file_.directory(); }
  // Bytes held in the process's memory (0 when spilled).
  std::size_t memory_bytes() const { return memory_.capacity() * sizeof(T); }

 private:
  std::vector<T> memory_;
  SpillFile file_;
  std::size_t size_ = 0;
};

}  // namespace ssrfleet::util
