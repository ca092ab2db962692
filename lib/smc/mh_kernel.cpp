#include "smc/mh_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Cholesky>
#include <boost/random/chi_squared_distribution.hpp>
#include <boost/random/normal_distribution.hpp>

#include "util/errors.hpp"

namespace ssrfleet::smc {

namespace {

// Stream key of the custom moves within a sweep (blocks use their index).
constexpr std::uint64_t kCustomMovesKey = ~std::uint64_t{0};
// Stream key of a block's independence step within a sweep (below the block's key).
constexpr std::uint64_t kIndependenceKey = 0x1d;

// log of the multivariate t density's kernel at a whitened offset (constants cancel in MH).
inline double log_t_kernel(double squared_mahalanobis, double df, Eigen::Index d) {
  return -0.5 * (df + static_cast<double>(d)) * std::log1p(squared_mahalanobis / df);
}

// log π_φ = log γ + φ ℓ, with 0 · (-inf) read as 0 (at φ = 0 the likelihood plays no part).
inline double log_target(double log_base, double loglik, double phi) {
  return phi == 0.0 ? log_base : log_base + phi * loglik;
}

void check_proposals(const Eigen::ArrayXd& log_base, const Eigen::ArrayXd& loglik, const BlockSpec& block,
                     std::string_view stage_label) {
  for (Eigen::Index i = 0; i < log_base.size(); ++i) {
    if (std::isnan(log_base[i]) || std::isnan(loglik[i]) ||
        loglik[i] == std::numeric_limits<double>::infinity() ||
        log_base[i] == std::numeric_limits<double>::infinity()) {
      std::ostringstream os;
      os << "stage '" << stage_label << "': block '" << block.name << "': log density at the proposal of particle "
         << i << " is not valid (log base " << log_base[i] << ", log-likelihood " << loglik[i] << ")";
      throw NumericalError(os.str());
    }
  }
}

}  // namespace

Eigen::MatrixXd weighted_covariance(const Eigen::Ref<const Eigen::MatrixXd>& X,
                                    const Eigen::Ref<const Eigen::ArrayXd>& W) {
  const double total = W.sum();
  const Eigen::VectorXd mean = X * W.matrix() / total;
  const Eigen::MatrixXd centred = X.colwise() - mean;
  return centred * W.matrix().asDiagonal() * centred.transpose() / total;
}

Eigen::MatrixXd proposal_covariance(const Eigen::Ref<const Eigen::MatrixXd>& X,
                                    const Eigen::Ref<const Eigen::ArrayXd>& W, double scale) {
  const Eigen::Index d = X.rows();
  Eigen::MatrixXd cov = weighted_covariance(X, W);
  const double mean_variance = cov.trace() / static_cast<double>(d);
  if (!std::isfinite(mean_variance) || !cov.allFinite())
    throw NumericalError("proposal_covariance: the weighted covariance of the cloud is not finite");
  if (!(mean_variance > 0.0))
    throw NumericalError("proposal_covariance: the particle cloud has collapsed to one point (zero spread)");
  // A relative ridge per coordinate: coordinates of a block may differ in scale by many orders of
  // magnitude (a stiffness in N/m beside a log-sd), so a ridge scaled on the mean variance would
  // swamp the small ones. A coordinate that has collapsed gets a ridge 1e-20 of the mean variance.
  for (Eigen::Index k = 0; k < d; ++k) cov(k, k) += 1e-10 * std::max(cov(k, k), 1e-10 * mean_variance);
  return (scale * scale / static_cast<double>(d)) * cov;
}

double tuned_scale_factor(double factor, double acceptance) {
  if (acceptance < 0.001) return factor * 0.1;
  if (acceptance < 0.05) return factor * 0.5;
  if (acceptance < 0.2) return factor * 0.9;
  if (acceptance > 0.95) return factor * 10.0;
  if (acceptance > 0.75) return factor * 2.0;
  if (acceptance > 0.5) return factor * 1.1;
  return factor;
}

MhSummary mh_moves(TemperedModel& model, double phi, const Eigen::Ref<const Eigen::ArrayXd>& W,
                   Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik,
                   const RngFactory& rngs, const ParallelFor& parallel, const MhOptions& options,
                   std::string_view stage_label) {
  const Eigen::Index P = model.particles();
  const std::vector<BlockSpec> blocks = model.blocks();
  const auto nb = blocks.size();

  MhSummary summary;
  summary.acceptance.assign(nb, 0.0);
  summary.jump.assign(nb, 0.0);
  for (const auto& b : blocks) summary.block_names.push_back(b.name);

  // Calibrate every block on the cloud as it is before moving (weighted, as particles does).
  std::vector<Eigen::MatrixXd> start(nb), chol_proposal(nb);
  std::vector<Eigen::LLT<Eigen::MatrixXd>> cloud(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    const Eigen::Index d = blocks[b].dim;
    start[b].resize(d, P);
    model.get_block(static_cast<int>(b), start[b]);
    Eigen::MatrixXd cov;
    try {
      cov = proposal_covariance(start[b], W, options.scale);
    } catch (const NumericalError& e) {
      throw NumericalError("stage '" + std::string(stage_label) + "': block '" + blocks[b].name + "': " + e.what());
    }
    Eigen::LLT<Eigen::MatrixXd> llt(cov);
    if (llt.info() != Eigen::Success)
      throw NumericalError("stage '" + std::string(stage_label) + "': block '" + blocks[b].name +
                           "': proposal covariance is not positive definite");
    chol_proposal[b] = llt.matrixL();
    // Σ̂ itself (undo the scale) for the jump distance.
    cloud[b].compute(cov * (static_cast<double>(d) / (options.scale * options.scale)));
  }

  // The independence proposal of each block: t_df(mean, (inflation² Σ̂)), Σ̂ the cloud's covariance.
  std::vector<Eigen::VectorXd> cloud_mean(nb);
  std::vector<Eigen::MatrixXd> chol_independent(nb);
  for (std::size_t b = 0; b < nb && options.independence; ++b) {
    cloud_mean[b] = start[b] * W.matrix() / W.sum();
    chol_independent[b] = options.independence_inflation * Eigen::MatrixXd(cloud[b].matrixL());
  }

  Eigen::MatrixXd current, proposed;
  Eigen::ArrayXd new_base(P), new_loglik(P), log_u(P), log_q_ratio(P);
  std::vector<char> accepted(static_cast<std::size_t>(P));
  std::vector<double> accepted_sum(nb, 0.0);
  std::vector<double> factor(nb, 1.0);
  std::vector<double> independence_sum(nb, 0.0), last_independence(nb, 1.0);
  std::vector<int> rw_steps(nb, 0);

  // One MH step of block b on every particle: proposals already in `proposed`, log_q_ratio the
  // log q(x) - log q(x') term (0 for a symmetric proposal). Returns the acceptance rate.
  auto mh_step = [&](std::size_t b) {
    model.log_density_at(static_cast<int>(b), proposed, new_base, new_loglik, parallel);
    check_proposals(new_base, new_loglik, blocks[b], stage_label);
    Eigen::Index n_accepted = 0;
    for (Eigen::Index i = 0; i < P; ++i) {
      const double log_ratio =
          log_target(new_base[i], new_loglik[i], phi) - log_target(log_base[i], loglik[i], phi) + log_q_ratio[i];
      const bool ok = log_u[i] < log_ratio;  // NaN (-inf - -inf) rejects
      accepted[static_cast<std::size_t>(i)] = ok ? 1 : 0;
      if (ok) {
        log_base[i] = new_base[i];
        loglik[i] = new_loglik[i];
        ++n_accepted;
      }
    }
    model.accept(static_cast<int>(b), accepted, proposed);
    return static_cast<double>(n_accepted) / static_cast<double>(P);
  };

  for (int sweep = 0; sweep < options.max_steps; ++sweep) {
    for (std::size_t b = 0; b < nb; ++b) {
      const Eigen::Index d = blocks[b].dim;
      current.resize(d, P);
      proposed.resize(d, P);
      const RngFactory block_rngs = rngs.child(static_cast<std::uint64_t>(sweep), static_cast<std::uint64_t>(b));
      if (options.independence) {
        model.get_block(static_cast<int>(b), current);
        const RngFactory ind_rngs = block_rngs.child(kIndependenceKey);
        const Eigen::MatrixXd& Li = chol_independent[b];
        const double df = options.independence_df;
        parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
          boost::random::normal_distribution<double> normal;
          boost::random::chi_squared_distribution<double> chi2(df);
          Eigen::VectorXd z(d);
          for (Eigen::Index i = begin; i < end; ++i) {
            Rng rng = ind_rngs.stream(static_cast<std::uint64_t>(i));
            for (Eigen::Index k = 0; k < d; ++k) z[k] = normal(rng);
            const double w = chi2(rng) / df;
            proposed.col(i) = cloud_mean[b] + Li.triangularView<Eigen::Lower>() * z / std::sqrt(w);
            const double q_new = z.squaredNorm() / w;
            const Eigen::VectorXd cur = Li.triangularView<Eigen::Lower>().solve(current.col(i) - cloud_mean[b]);
            log_q_ratio[i] = log_t_kernel(cur.squaredNorm(), df, d) - log_t_kernel(q_new, df, d);
            log_u[i] = std::log(uniform01(rng));
          }
        });
        last_independence[b] = mh_step(b);
        independence_sum[b] += last_independence[b];
        if (last_independence[b] >= options.independence_min_acceptance) continue;  // no random walk needed
      }
      model.get_block(static_cast<int>(b), current);
      const Eigen::MatrixXd L = factor[b] * chol_proposal[b];
      parallel(P, [&](Eigen::Index begin, Eigen::Index end) {
        boost::random::normal_distribution<double> normal;
        Eigen::VectorXd z(d);
        for (Eigen::Index i = begin; i < end; ++i) {
          Rng rng = block_rngs.stream(static_cast<std::uint64_t>(i));
          for (Eigen::Index k = 0; k < d; ++k) z[k] = normal(rng);
          proposed.col(i) = current.col(i) + L.triangularView<Eigen::Lower>() * z;
          log_u[i] = std::log(uniform01(rng));
        }
      });
      log_q_ratio.setZero();
      const double rate = mh_step(b);
      ++rw_steps[b];
      accepted_sum[b] += rate;
      if (options.adapt_scale) factor[b] = tuned_scale_factor(factor[b], rate);
    }
    model.custom_moves(phi, rngs.child(static_cast<std::uint64_t>(sweep), kCustomMovesKey), parallel, log_base,
                       loglik);
    summary.sweeps = sweep + 1;

    // How far has the cloud moved since the start? (weighted mean squared Mahalanobis jump / 2d)
    bool far_enough = true;
    for (std::size_t b = 0; b < nb; ++b) {
      const Eigen::Index d = blocks[b].dim;
      current.resize(d, P);
      model.get_block(static_cast<int>(b), current);
      const Eigen::MatrixXd whitened = cloud[b].matrixL().solve(current - start[b]);
      summary.jump[b] = (whitened.colwise().squaredNorm().array().transpose() * W).sum() / W.sum() /
                        (2.0 * static_cast<double>(d));
      far_enough = far_enough && summary.jump[b] >= options.jump_target;
    }
    if (summary.sweeps >= options.min_steps && far_enough) break;
  }
  for (std::size_t b = 0; b < nb; ++b) {
    // Acceptance of the random-walk steps (or of the independence steps if no random walk ran).
    summary.acceptance[b] = rw_steps[b] > 0 ? accepted_sum[b] / rw_steps[b] : independence_sum[b] / summary.sweeps;
    summary.independence_acceptance.push_back(options.independence ? independence_sum[b] / summary.sweeps : -1.0);
    summary.random_walk_steps.push_back(rw_steps[b]);
  }
  summary.scale_factor = factor;
  return summary;
}

}  // namespace ssrfleet::smc
