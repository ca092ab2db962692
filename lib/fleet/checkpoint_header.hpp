// The first words of every core's checkpoint: a magic word, the format version, the site's
// fingerprint and the seed. A resume must be on the same site with the same seed; the version says
// which core wrote it (1: the latent core of ssrfleet 0.1; 2: the marginal core).
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include <Eigen/Core>

#include "site/site.hpp"
#include "util/binary_io.hpp"

namespace ssrfleet::fleet {

inline constexpr std::uint64_t kCheckpointMagic = 0x54504b4346525353ULL;  // "SSRFCKPT"

// `fingerprint`: the site's (site::Site::fingerprint), or the sites' (fleet/joint_sites.hpp).
inline void write_checkpoint_header(BinaryWriter& out, std::uint32_t version, const std::string& fingerprint,
                                    std::uint64_t seed) {
  out.value(kCheckpointMagic);
  out.value(version);
  out.text(fingerprint);
  out.value(seed);
}
inline void write_checkpoint_header(BinaryWriter& out, std::uint32_t version, const site::Site& site,
                                    std::uint64_t seed) {
  write_checkpoint_header(out, version, site.fingerprint(), seed);
}

// Reads and checks the header; `explain_version` turns a version this core does not read into the
// reason given with the DataError (the caller's wording, e.g. what to do with an old state).
inline void read_checkpoint_header(BinaryReader& in, std::uint32_t version, const std::string& fingerprint,
                                   std::uint64_t seed, const std::function<std::string(std::uint32_t)>& explain_version) {
  if (in.value<std::uint64_t>("magic") != kCheckpointMagic) in.fail("magic", "not an ssrfleet checkpoint");
  const auto found = in.value<std::uint32_t>("version");
  if (found != version) in.fail("version", explain_version(found));
  if (in.text("site") != fingerprint) {
    in.fail("site", "the checkpoint belongs to another site (road or site options differ)");
  }
  if (in.value<std::uint64_t>("seed") != seed) {
    in.fail("seed", "the checkpoint was made with another seed; resume with the seed it started with");
  }
}
inline void read_checkpoint_header(BinaryReader& in, std::uint32_t version, const site::Site& site, std::uint64_t seed,
                                   const std::function<std::string(std::uint32_t)>& explain_version) {
  read_checkpoint_header(in, version, site.fingerprint(), seed, explain_version);
}

// The particles' log weights, whose count must be this run's: a resume with another --particles
// is named as such, not as a matrix of the wrong shape.
inline Eigen::ArrayXd read_log_weights(BinaryReader& in, Eigen::Index particles) {
  const Eigen::MatrixXd w = in.matrix("log_weights", -1, 1);
  if (w.rows() != particles) {
    in.fail("particles", "the state holds " + std::to_string(w.rows()) + " particles and this run asks for " +
                             std::to_string(particles) + ": resume with --particles " + std::to_string(w.rows()));
  }
  return w.array();
}

}  // namespace ssrfleet::fleet
