// A plain byte codec (it knows no file format and no model): native-endian binary values, strings
// and Eigen arrays, written to and read from any stream. Its user is the checkpoint file (fleet and
// stream save and restore through it), which is why it lives in util, below both.
// A checkpoint is read back on the machine that wrote it (a stream resuming after a crash), so
// native layout is enough; a magic word and a version guard against anything else.
// Reading past the end or a size that does not fit is a DataError naming the file.
// Seals: both sides keep a running FNV-1a 64-bit hash of the bytes since the last seal; the writer's
// seal() appends it, the reader's check_seal() compares, so a byte changed after writing (a bad
// disk, a partial copy) is a DataError naming the file instead of a wrong state.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <type_traits>

#include <Eigen/Core>

#include "util/errors.hpp"

namespace ssrfleet {

namespace detail {
inline constexpr std::uint64_t kFnvOffset = 0xcbf29ce484222325ULL, kFnvPrime = 0x100000001b3ULL;
inline std::uint64_t fnv1a(std::uint64_t hash, const char* bytes, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) hash = (hash ^ static_cast<unsigned char>(bytes[i])) * kFnvPrime;
  return hash;
}
}  // namespace detail

class BinaryWriter {
 public:
  explicit BinaryWriter(std::ostream& out) : out_(out) {}
  template <class T>
  void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    put(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void text(const std::string& s) {
    value<std::uint64_t>(s.size());
    put(s.data(), s.size());
  }
  template <class Derived>
  void matrix(const Eigen::DenseBase<Derived>& m) {
    value<std::int64_t>(m.rows());
    value<std::int64_t>(m.cols());
    const auto plain = m.derived().eval();
    put(reinterpret_cast<const char*>(plain.data()), static_cast<std::size_t>(plain.size()) * sizeof(double));
  }
  // Appends the hash of everything written since the last seal, and starts a new one.
  void seal() {
    last_seal_ = hash_;
    out_.write(reinterpret_cast<const char*>(&last_seal_), sizeof last_seal_);
    hash_ = detail::kFnvOffset;
    since_seal_ = 0;
  }
  // The checksum the last seal() wrote (a record elsewhere may name the file by it).
  std::uint64_t last_seal() const { return last_seal_; }
  // Appends bytes that another writer wrote from a seal boundary and ended with seal() (a record
  // built elsewhere: on another MPI rank). Only at a seal boundary of this writer (nothing written
  // since its last seal), so they read back exactly as if this writer had written them.
  void sealed_bytes(const std::string& bytes) {
    if (since_seal_ != 0 || bytes.size() < sizeof last_seal_) {
      throw std::logic_error("BinaryWriter::sealed_bytes: not at a seal boundary, or not a sealed record");
    }
    out_.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    std::memcpy(&last_seal_, bytes.data() + bytes.size() - sizeof last_seal_, sizeof last_seal_);
  }

 private:
  void put(const char* bytes, std::size_t n) {
    out_.write(bytes, static_cast<std::streamsize>(n));
    hash_ = detail::fnv1a(hash_, bytes, n);
    since_seal_ += n;
  }
  std::ostream& out_;
  std::uint64_t since_seal_ = 0;
  std::uint64_t hash_ = detail::kFnvOffset;
  std::uint64_t last_seal_ = 0;
};

class BinaryReader {
 public:
  BinaryReader(std::istream& in, std::string source) : in_(in), source_(std::move(source)) {}
  template <class T>
  T value(const char* what) {
    static_assert(std::is_trivially_copyable_v<T>);
    T v{};
    get(reinterpret_cast<char*>(&v), sizeof v, what);
    return v;
  }
  std::string text(const char* what, std::size_t max_size = 1 << 20) {
    const auto n = value<std::uint64_t>(what);
    if (n > max_size) fail(what, "implausible length");
    std::string s(n, '\0');
    get(s.data(), n, what);
    return s;
  }
  // A matrix whose shape must be rows x cols (-1 = any).
  Eigen::MatrixXd matrix(const char* what, Eigen::Index rows = -1, Eigen::Index cols = -1) {
    const auto r = value<std::int64_t>(what), c = value<std::int64_t>(what);
    if (r < 0 || c < 0 || (rows >= 0 && r != rows) || (cols >= 0 && c != cols) || r * c > (std::int64_t{1} << 32)) {
      fail(what, "unexpected shape " + std::to_string(r) + " x " + std::to_string(c));
    }
    Eigen::MatrixXd m(r, c);
    get(reinterpret_cast<char*>(m.data()), static_cast<std::size_t>(m.size()) * sizeof(double), what);
    return m;
  }
  // Reads the writer's seal and compares it with the hash of what was read since the last one.
  void check_seal(const char* what) {
    const std::uint64_t expected = hash_;
    std::uint64_t sealed = 0;
    in_.read(reinterpret_cast<char*>(&sealed), sizeof sealed);
    if (!in_) fail(what, "file ends early (no checksum)");
    if (sealed != expected) fail(what, "checksum mismatch: the file was changed or damaged after it was written");
    hash_ = detail::kFnvOffset;
    last_seal_ = sealed;
  }
  // The checksum the last check_seal() verified.
  std::uint64_t last_seal() const { return last_seal_; }
  [[noreturn]] void fail(const char* what, const std::string& why) const { throw DataError(source_, 0, what, why); }

 private:
  void get(char* bytes, std::size_t n, const char* what) {
    in_.read(bytes, static_cast<std::streamsize>(n));
    if (!in_) fail(what, "file ends early");
    hash_ = detail::fnv1a(hash_, bytes, n);
  }
  std::istream& in_;
  std::string source_;
  std::uint64_t hash_ = detail::kFnvOffset;
  std::uint64_t last_seal_ = 0;
};

}  // namespace ssrfleet
