// MarginalTarget's own move (marginal_target.hpp, model_moves): an extension's jump of (K, σ_k, ψ)
// between distant modes of the stiffness distribution, e.g. two classes trading places, which the
// block moves fitted to the cloud cannot cross once the cloud has settled in one of them.
#include <cmath>
#include <stdexcept>

#include "fleet/marginal_target.hpp"

namespace ssrfleet::fleet {

namespace {
constexpr std::uint64_t kStiffnessJumpStream = 0x53544a4d50ULL;  // "STJMP": this move's random streams
constexpr double kNegInf = -std::numeric_limits<double>::infinity();
}  // namespace

std::vector<std::string> MarginalTarget::model_moves() const {
  if (options_.extension != nullptr && options_.extension->stiffness_jump_draws() > 0) return {"stiffness jump"};
  return {};
}

smc::TemperedModel::ModelMoveResult MarginalTarget::run_model_move(int move, int /*run_in_stage*/, double phi,
                                                                   const smc::RngFactory& rngs,
                                                                   const smc::ParallelFor& parallel,
                                                                   Eigen::Ref<Eigen::ArrayXd> log_base,
                                                                   Eigen::Ref<Eigen::ArrayXd> loglik) {
  if (move != 0 || model_moves().empty()) {
    throw std::logic_error("MarginalTarget::run_model_move: no model move " + std::to_string(move));
  }
  const ModelExtension& ext = *options_.extension;
  const Eigen::Index P = options_.particles, d = kHyperCount + psi_dim();
  const auto draws = static_cast<std::size_t>(ext.stiffness_jump_draws());
  Eigen::MatrixXd proposed(d, P);
  std::vector<char> valid(static_cast<std::size_t>(P), 0);
  std::vector<double> log_u(static_cast<std::size_t>(P)), jacobian_now(static_cast<std::size_t>(P)),
      jacobian_new(static_cast<std::size_t>(P));
  const smc::RngFactory streams = rngs.child(kStiffnessJumpStream);
  // The proposals, each particle from its own stream (the same bits at any thread count).
  for (Eigen::Index p = 0; p < P; ++p) {
    smc::Rng rng = streams.stream(static_cast<std::uint64_t>(p));
    std::vector<double> u(draws), psi_new(static_cast<std::size_t>(psi_dim()));
    for (double& x : u) x = smc::uniform01(rng);
    log_u[static_cast<std::size_t>(p)] = std::log(smc::uniform01(rng));
    const HyperVector now = theta_of(p);
    HyperVector next = now;
    ext.stiffness_jump(psi_of(p), now[kK], now[kSigmaK], u.data(), psi_new.data(), &next[kK], &next[kSigmaK]);
    const bool ok = next[kSigmaK] > 0.0 && ext.in_prior(psi_new.data()) && options_.prior.log_prior(next) > kNegInf;
    valid[static_cast<std::size_t>(p)] = ok ? 1 : 0;
    // An impossible proposal is evaluated at the particle's own state and rejected below.
    if (ok) {
      encode(next, psi_new.data(), proposed.col(p).data());
      jacobian_new[static_cast<std::size_t>(p)] = log_jacobian(next, psi_new.data());
    } else {
      encode(now, psi_of(p), proposed.col(p).data());
    }
    jacobian_now[static_cast<std::size_t>(p)] = log_jacobian(now, psi_of(p));
  }
  Eigen::ArrayXd proposed_base(P), proposed_lik(P);
  log_density_at(0, proposed, proposed_base, proposed_lik, parallel);
  // The jump is symmetric in (K, σ_k, ψ) themselves, so the ratio is of the target's density there:
  // the move coordinates' Jacobian comes off both sides.
  std::vector<char> accepted(static_cast<std::size_t>(P), 0);
  long taken = 0;
  for (Eigen::Index p = 0; p < P; ++p) {
    const auto i = static_cast<std::size_t>(p);
    if (!valid[i] || !(proposed_base[p] > kNegInf)) continue;
    const double now = log_base[p] - jacobian_now[i] + phi * loglik[p];
    const double next = proposed_base[p] - jacobian_new[i] + phi * proposed_lik[p];
    if (log_u[i] < next - now) {
      accepted[i] = 1;
      ++taken;
      log_base[p] = proposed_base[p];
      loglik[p] = proposed_lik[p];
    }
  }
  accept(0, accepted, proposed);
  ModelMoveResult r;
  r.acceptance = static_cast<double>(taken) / static_cast<double>(P);
  return r;
}

}  // namespace ssrfleet::fleet
