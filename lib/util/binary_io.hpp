// A plain byte codec (it knows no file format and no model): native-endian binary values, strings
// and Eigen arrays, written to and read from any stream. Its user is the checkpoint file (fleet and
// stream save and restore through it), which is why it lives in util, below both.
// A checkpoint is read back on the machine that wrote it (a stream resuming after a crash), so
// native layout is enough; a magic word and a version guard against anything else.
// Reading past the end or a size that does not fit is a DataError naming the file.
#pragma once

#include <cstdint>
#include <istream>
#include <ostream>
#include <string>
#include <type_traits>

#include <Eigen/Core>

#include "util/errors.hpp"

namespace ssrfleet {

class BinaryWriter {
 public:
  explicit BinaryWriter(std::ostream& out) : out_(out) {}
  template <class T>
  void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.write(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void text(const std::string& s) {
    value<std::uint64_t>(s.size());
    out_.write(s.data(), static_cast<std::streamsize>(s.size()));
  }
  template <class Derived>
  void matrix(const Eigen::DenseBase<Derived>& m) {
    value<std::int64_t>(m.rows());
    value<std::int64_t>(m.cols());
    const auto plain = m.derived().eval();
    out_.write(reinterpret_cast<const char*>(plain.data()), static_cast<std::streamsize>(plain.size() * sizeof(double)));
  }

 private:
  std::ostream& out_;
};

class BinaryReader {
 public:
  BinaryReader(std::istream& in, std::string source) : in_(in), source_(std::move(source)) {}
  template <class T>
  T value(const char* what) {
    static_assert(std::is_trivially_copyable_v<T>);
    T v{};
    in_.read(reinterpret_cast<char*>(&v), sizeof v);
    if (!in_) fail(what, "file ends early");
    return v;
  }
  std::string text(const char* what, std::size_t max_size = 1 << 20) {
    const auto n = value<std::uint64_t>(what);
    if (n > max_size) fail(what, "implausible length");
    std::string s(n, '\0');
    in_.read(s.data(), static_cast<std::streamsize>(n));
    if (!in_) fail(what, "file ends early");
    return s;
  }
  // A matrix whose shape must be rows x cols (-1 = any).
  Eigen::MatrixXd matrix(const char* what, Eigen::Index rows = -1, Eigen::Index cols = -1) {
    const auto r = value<std::int64_t>(what), c = value<std::int64_t>(what);
    if (r < 0 || c < 0 || (rows >= 0 && r != rows) || (cols >= 0 && c != cols) || r * c > (std::int64_t{1} << 32)) {
      fail(what, "unexpected shape " + std::to_string(r) + " x " + std::to_string(c));
    }
    Eigen::MatrixXd m(r, c);
    in_.read(reinterpret_cast<char*>(m.data()), static_cast<std::streamsize>(m.size() * sizeof(double)));
    if (!in_) fail(what, "file ends early");
    return m;
  }
  [[noreturn]] void fail(const char* what, const std::string& why) const { throw DataError(source_, 0, what, why); }

 private:
  std::istream& in_;
  std::string source_;
};

}  // namespace ssrfleet
