// The latent core's checkpoint: every particle's θ, ψ and latents and the trucks' data, in the order
// FleetTarget::load reads them back. The layout still holds the fields of a bounded-memory mode the
// core once had (a window, the sums of the trucks that left it, a pool of their speeds and masses),
// written as that mode's "off" (0, zeros, every truck), so that states written then in the exact
// mode resume bit for bit; a state written with a window is refused by name.
#include <algorithm>
#include <cstdint>
#include <string>

#include "fleet/fleet_target.hpp"
#include "util/binary_io.hpp"
#include "util/errors.hpp"

namespace ssrfleet::fleet {

void FleetTarget::save(BinaryWriter& out) const {
  out.value<std::int64_t>(options_.particles);
  out.value<std::int32_t>(sensors_);
  out.value<std::int64_t>(0);  // window
  out.value<std::int64_t>(kept_trucks());
  out.matrix(Eigen::MatrixXd::Zero(kSumCount, options_.particles));  // sums of trucks out of the window
  out.value<std::uint64_t>(speed_mps_.size());                         // the prediction pool: every truck
  for (std::size_t j = 0; j < speed_mps_.size(); ++j) {
    out.value(speed_mps_[j]);
    out.value(sprung_mass_kg_[j]);
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
  const auto window = in.value<std::int64_t>("window");
  if (window != 0) {
    in.fail("window", "written with --window " + std::to_string(window) +
                          ", a bounded-memory approximation this ssrfleet no longer has: replay the log into a new "
                          "state (the default core's memory per truck is flat)");
  }
  const auto total_trucks = in.value<std::int64_t>("total_trucks");
  if (!in.matrix("retired", kSumCount, P).isZero(0.0)) in.fail("retired", "sums of retired trucks without a window");
  const auto pool = in.value<std::uint64_t>("pool");
  if (pool != static_cast<std::uint64_t>(std::max<std::int64_t>(total_trucks, 0))) {
    in.fail("pool", "does not hold every truck absorbed");
  }
  for (std::uint64_t j = 0; j < 2 * pool; ++j) (void)in.value<double>("pool");  // the trucks' own data follow
  const auto n = in.value<std::int64_t>("trucks");
  if (n != total_trucks) in.fail("trucks", "not every truck absorbed kept");
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
