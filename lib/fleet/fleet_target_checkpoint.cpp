// The latent core's checkpoint: every particle's θ, ψ and sums, and the kept trucks' latents, in
// the order FleetTarget::load reads them back.
#include <cstdint>
#include <string>

#include "fleet/fleet_target.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

void FleetTarget::save(BinaryWriter& out) const {
  out.value<std::int64_t>(options_.particles);
  out.value<std::int32_t>(sensors_);
  out.value<std::int64_t>(options_.window);
  out.value<std::int64_t>(total_trucks_);
  out.matrix(retired_);
  out.value<std::uint64_t>(pool_speed_mps_.size());
  for (std::size_t j = 0; j < pool_speed_mps_.size(); ++j) {
    out.value(pool_speed_mps_[j]);
    out.value(pool_sprung_mass_kg_[j]);
  }
  out.value<std::int64_t>(kept_trucks());
  for (Eigen::Index j = 0; j < kept_trucks(); ++j) {
    out.value(speed_mps_[static_cast<std::size_t>(j)]);
    out.value(sprung_mass_kg_[static_cast<std::size_t>(j)]);
    out.matrix(observed_if_[static_cast<std::size_t>(j)]);
  }
  out.matrix(theta_);
  out.matrix(latents_);
  out.matrix(ssr_);
  out.value<std::uint64_t>(older_scale_.size());
  for (double v : older_scale_) out.value(v);
  out.value(interweave_scale_);
  if (psi_.rows() > 0) {  // only with an extension, so checkpoints without one keep their format
    out.matrix(psi_);
    out.value(extension_scale_);
    out.value(stiffness_scale_);
  }
}

void FleetTarget::load(BinaryReader& in) {
  const Eigen::Index P = options_.particles;
  if (in.value<std::int64_t>("particles") != P) in.fail("particles", "saved with another particle count");
  if (in.value<std::int32_t>("sensors") != sensors_) in.fail("sensors", "saved for another sensor count");
  if (in.value<std::int64_t>("window") != options_.window) in.fail("window", "saved with another --window");
  total_trucks_ = in.value<std::int64_t>("total_trucks");
  retired_ = in.matrix("retired", kSumCount, P);
  const auto pool = in.value<std::uint64_t>("pool");
  if (pool > static_cast<std::uint64_t>(total_trucks_)) in.fail("pool", "larger than the trucks absorbed");
  pool_speed_mps_.clear();
  pool_sprung_mass_kg_.clear();
  for (std::uint64_t j = 0; j < pool; ++j) {
    pool_speed_mps_.push_back(in.value<double>("pool_speed_mps"));
    pool_sprung_mass_kg_.push_back(in.value<double>("pool_sprung_mass_kg"));
  }
  const auto n = in.value<std::int64_t>("trucks");
  if (n > total_trucks_) in.fail("trucks", "more kept trucks than absorbed");
  if (n < 0 || n > 100'000'000) in.fail("trucks", "implausible truck count");
  speed_mps_.clear();
  sprung_mass_kg_.clear();
  observed_if_.clear();
  for (std::int64_t j = 0; j < n; ++j) {
    speed_mps_.push_back(in.value<double>("speed_mps"));
    sprung_mass_kg_.push_back(in.value<double>("sprung_mass_kg"));
    observed_if_.push_back(in.matrix("impact_factor", sensors_, 1));
  }
  theta_ = in.matrix("theta", kHyperCount, P);
  latents_ = in.matrix("latents", 3 * n, P);
  ssr_ = in.matrix("ssr", n, P);
  const auto scales = in.value<std::uint64_t>("older_scale");
  if (scales != static_cast<std::uint64_t>(n > 0 ? n - 1 : 0)) in.fail("older_scale", "size does not match the trucks");
  older_scale_.assign(scales, 1.0);
  for (auto& v : older_scale_) v = in.value<double>("older_scale");
  interweave_scale_ = in.value<double>("interweave_scale");
  if (psi_.rows() > 0) {
    psi_ = in.matrix("psi", psi_.rows(), P);
    extension_scale_ = in.value<double>("extension_scale");
    stiffness_scale_ = in.value<double>("stiffness_scale");
  }
  for (Eigen::Index i = 0; i < P; ++i) recompute_sums(i);
  newest_from_proposals_ = false;  // a checkpoint falls between stages, where the proposals play no part
}

}  // namespace ssrfleet::fleet
