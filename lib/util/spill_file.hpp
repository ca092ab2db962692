// An append-only run of bytes kept in a file the kernel pages, not in the process's own memory:
// an unnamed temporary file in a given directory (O_TMPFILE, or created and unlinked at once),
// read through a shared mapping. Its pages are page cache: written back to the file, dropped under
// memory pressure and read back on the next touch, so a process whose data grows with its input (a
// stream's truck tables, model/table_store.hpp) keeps its private memory flat while the data is
// still read at memory speed whenever it fits in RAM. The file has no name, so a crash leaves
// nothing behind; its blocks are freed when the object is destroyed.
//
// Appends go through pwrite(2), so a full disk is an IoError naming the directory, never a SIGBUS
// from a store into a mapped hole. The mapping is read-only and only ever read below the bytes
// written.
#pragma once

#include <cstddef>
#include <string>

namespace ssrfleet::util {

class SpillFile {
 public:
  SpillFile() = default;
  // IoError if no file can be made in `directory`.
  explicit SpillFile(const std::string& directory);
  ~SpillFile();
  SpillFile(SpillFile&& other) noexcept;
  SpillFile& operator=(SpillFile&& other) noexcept;
  SpillFile(const SpillFile&) = delete;
  SpillFile& operator=(const SpillFile&) = delete;

  bool is_open() const { return fd_ >= 0; }
  // The directory the file is in ("" when not open).
  const std::string& directory() const { return directory_; }
  // Appends n bytes at size() (IoError on a write error: size() is then unchanged).
  void append(const void* bytes, std::size_t n);
  // Overwrites n bytes at `offset` (offset + n <= size(); IoError on a write error).
  void write_at(std::size_t offset, const void* bytes, std::size_t n);
  // Forgets the bytes from `bytes` on (a no-op if there are fewer).
  void shrink_to(std::size_t bytes);
  // The bytes written so far, valid until the next append (which may move the mapping).
  const std::byte* data() const { return map_; }
  std::size_t size() const { return size_; }

 private:
  void map_at_least(std::size_t bytes);
  std::string write_all(std::size_t offset, const void* bytes, std::size_t n) const;
  void release() noexcept;

  std::string directory_;
  int fd_ = -1;
  std::byte* map_ = nullptr;
  std::size_t mapped_ = 0;  // length of the mapping (may run past the end of the file)
  std::size_t size_ = 0;
};

}  // namespace ssrfleet::util
