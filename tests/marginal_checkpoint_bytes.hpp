// A marginal-core fit's checkpoint as bytes and back, as `fit --checkpoint` and a stream write and
// read checkpoint.bin: for the tests of resumes and state formats.
#pragma once

#include <sstream>
#include <string>

#include "fleet/marginal_smc.hpp"
#include "util/binary_io.hpp"

namespace ssrfleet::test {

inline std::string bytes_of(const fleet::MarginalSmc& smc) {
  std::ostringstream os;
  BinaryWriter w(os);
  smc.save(w);
  return os.str();
}

// Restores a core from a checkpoint's bytes (bytes_of's), as a resume reads checkpoint.bin.
inline void restore_from(fleet::MarginalSmc& smc, const std::string& bytes) {
  std::istringstream is(bytes);
  BinaryReader in(is, "checkpoint.bin");
  smc.restore(in);
}

}  // namespace ssrfleet::test
