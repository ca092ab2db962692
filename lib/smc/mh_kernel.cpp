#include "smc/mh_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Cholesky>
#include <boost/random/chi_squared_distribution.hpp>
#include <boost/random/normal_distribution.hpp>

#include "util/errors.hpp"
#include "util/stop_token.hpp"

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

const MoveRecord* MhSummary::find(std::string_view move, std::string_view block) const {
  for (const MoveRecord& r : moves)
    if (r.move == move && r.block == block) return &r;
  return nullptr;
}

namespace {

// One block move of every particle: proposes (into `proposed`, with log_q_ratio the log q(x) -
// log q(x') term, 0 for a symmetric proposal), asks the model, accepts per particle, and returns
// the share accepted. Everything a block's moves share within one call of run_sweeps.
struct BlockMoves {
  BlockMoves(TemperedModel& model_, double phi_, Eigen::Ref<Eigen::ArrayXd> log_base_, Eigen::Ref<Eigen::ArrayXd> loglik_,
             const ParallelFor& parallel_, const MhOptions& proposal_, const std::vector<BlockSpec>& blocks_,
             std::string_view stage_label_)
      : model(model_), phi(phi_), log_base(log_base_), loglik(loglik_), parallel(parallel_), proposal(proposal_),
        blocks(blocks_), stage_label(stage_label_), P(model_.particles()), new_base(P), new_loglik(P), log_u(P),
        log_q_ratio(P), accepted(static_cast<std::size_t>(P)) {}

  TemperedModel& model;
  double phi;
  Eigen::Ref<Eigen::ArrayXd> log_base, loglik;
  const ParallelFor& parallel;
  const MhOptions& proposal;
  const std::vector<BlockSpec>& blocks;
  std::string_view stage_label;
  Eigen::Index P;
  // Per block: the cloud before moving (its covariance's Cholesky factor for the jump distance),
  // the random walk's factor and the independence proposal's centre and factor.
  std::vector<Eigen::MatrixXd> start, chol_proposal, chol_independent;
  std::vector<Eigen::LLT<Eigen::MatrixXd>> cloud;
  std::vector<Eigen::VectorXd> cloud_mean;
  std::vector<double> factor;  // adapted random-walk multiplier
  Eigen::MatrixXd current, proposed;
  Eigen::ArrayXd new_base, new_loglik, log_u, log_q_ratio;
  std::vector<char> accepted;

  double mh_step(std::size_t b) {
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
  }

  double independence(std::size_t b, const RngFactory& block_rngs) {
    const Eigen::Index d = blocks[b].dim;
    current.resize(d, P);
    proposed.resize(d, P);
    model.get_block(static_cast<int>(b), current);
    const RngFactory ind_rngs = block_rngs.child(kIndependenceKey);
    const Eigen::MatrixXd& Li = chol_independent[b];
    const double df = proposal.independence_df;
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
    return mh_step(b);
  }

  double random_walk(std::size_t b, const RngFactory& block_rngs) {
    const Eigen::Index d = blocks[b].dim;
    current.resize(d, P);
    proposed.resize(d, P);
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
    if (proposal.adapt_scale) factor[b] = tuned_scale_factor(factor[b], rate);
    return rate;
  }
};

// Calibrates every block on the cloud as it is before moving (weighted, as particles does).
void calibrate(BlockMoves& m, const Eigen::Ref<const Eigen::ArrayXd>& W, bool with_independence) {
  const std::size_t nb = m.blocks.size();
  m.start.resize(nb);
  m.chol_proposal.resize(nb);
  m.chol_independent.resize(nb);
  m.cloud.resize(nb);
  m.cloud_mean.resize(nb);
  m.factor.assign(nb, 1.0);
  for (std::size_t b = 0; b < nb; ++b) {
    const Eigen::Index d = m.blocks[b].dim;
    m.start[b].resize(d, m.P);
    m.model.get_block(static_cast<int>(b), m.start[b]);
    Eigen::MatrixXd cov;
    try {
      cov = proposal_covariance(m.start[b], W, m.proposal.scale);
    } catch (const NumericalError& e) {
      throw NumericalError("stage '" + std::string(m.stage_label) + "': block '" + m.blocks[b].name + "': " + e.what());
    }
    Eigen::LLT<Eigen::MatrixXd> llt(cov);
    if (llt.info() != Eigen::Success)
      throw NumericalError("stage '" + std::string(m.stage_label) + "': block '" + m.blocks[b].name +
                           "': proposal covariance is not positive definite");
    m.chol_proposal[b] = llt.matrixL();
    // Σ̂ itself (undo the scale) for the jump distance.
    m.cloud[b].compute(cov * (static_cast<double>(d) / (m.proposal.scale * m.proposal.scale)));
    if (with_independence) {
      // t_df(mean, inflation² Σ̂), Σ̂ the cloud's covariance.
      m.cloud_mean[b] = m.start[b] * W.matrix() / W.sum();
      m.chol_independent[b] = m.proposal.independence_inflation * Eigen::MatrixXd(m.cloud[b].matrixL());
    }
  }
}

void record_run(MoveRecord& r, double acceptance) {
  const double sum = (r.runs > 0 && !std::isnan(r.acceptance) ? r.acceptance * r.runs : 0.0);
  ++r.runs;
  if (!std::isnan(acceptance)) r.acceptance = (sum + acceptance) / r.runs;
}

}  // namespace

MhSummary run_sweeps(TemperedModel& model, double phi, const Eigen::Ref<const Eigen::ArrayXd>& W,
                     Eigen::Ref<Eigen::ArrayXd> log_base, Eigen::Ref<Eigen::ArrayXd> loglik, const RngFactory& rngs,
                     const ParallelFor& parallel, const MhOptions& proposal, const MoveSchedule& schedule,
                     int min_sweeps, int max_sweeps, std::vector<int>& runs_in_stage, std::string_view stage_label,
                     const SweepObserver& after_sweep) {
  const Eigen::Index P = model.particles();
  const std::vector<BlockSpec> blocks = model.blocks();
  const std::size_t nb = blocks.size(), ns = schedule.sweep.size();
  runs_in_stage.resize(ns, 0);

  // Which model move each kModel entry names.
  const std::vector<std::string> model_moves = model.model_moves();
  std::vector<int> model_index(ns, -1);
  bool with_independence = false;
  for (std::size_t e = 0; e < ns; ++e) {
    const ScheduledMove& s = schedule.sweep[e];
    with_independence = with_independence || s.kind == MoveKind::kIndependence;
    if (s.kind != MoveKind::kModel) continue;
    const auto it = std::find(model_moves.begin(), model_moves.end(), s.model_move);
    if (it == model_moves.end())
      throw UsageError("stage '" + std::string(stage_label) + "': the move schedule names model move '" +
                       s.model_move + "', which the model does not have");
    model_index[e] = static_cast<int>(it - model_moves.begin());
  }

  MhSummary summary;
  summary.acceptance.assign(nb, 0.0);
  summary.jump.assign(nb, 0.0);
  for (const auto& b : blocks) summary.block_names.push_back(b.name);
  // One record per entry and block (model moves: one per entry), in schedule order.
  std::vector<std::vector<std::size_t>> record_of(ns);
  for (std::size_t e = 0; e < ns; ++e) {
    const ScheduledMove& s = schedule.sweep[e];
    if (s.kind == MoveKind::kModel) {
      record_of[e].push_back(summary.moves.size());
      summary.moves.push_back({s.model_move, "", 0, 0});
    } else {
      for (std::size_t b = 0; b < nb; ++b) {
        record_of[e].push_back(summary.moves.size());
        summary.moves.push_back({to_string(s.kind), blocks[b].name, 0, 0});
      }
    }
  }

  BlockMoves m(model, phi, log_base, loglik, parallel, proposal, blocks, stage_label);
  calibrate(m, W, with_independence);

  auto allowed = [&](std::size_t e) {
    const ScheduledMove& s = schedule.sweep[e];
    if (s.only_at_phi_one && phi != 1.0) return false;
    return s.max_runs_per_stage < 0 || runs_in_stage[e] < s.max_runs_per_stage;
  };

  std::vector<double> rw_sum(nb, 0.0), ind_sum(nb, 0.0);
  std::vector<int> rw_runs(nb, 0), ind_runs(nb, 0);
  for (int sweep = 0; sweep < max_sweeps; ++sweep) {
    util::throw_if_stopped();
    for (std::size_t e = 0; e < ns;) {
      if (schedule.sweep[e].kind == MoveKind::kModel) {
        MoveRecord& r = summary.moves[record_of[e].front()];
        if (!allowed(e)) {
          ++r.skipped;
        } else {
          const TemperedModel::ModelMoveResult res =
              model.run_model_move(model_index[e], runs_in_stage[e], phi,
                                   rngs.child(static_cast<std::uint64_t>(sweep), kCustomMovesKey), parallel, log_base,
                                   loglik);
          if (res.ran) {
            record_run(r, res.acceptance);
            ++runs_in_stage[e];
          } else {
            ++r.skipped;
          }
        }
        ++e;
        continue;
      }
      // A run of consecutive block moves runs block by block, each block's moves in order, so the
      // fallback condition reads the move just made on the same block.
      std::size_t group_end = e;
      while (group_end < ns && schedule.sweep[group_end].kind != MoveKind::kModel) ++group_end;
      std::vector<bool> ran_in_group(group_end - e, false);
      for (std::size_t b = 0; b < nb; ++b) {
        const RngFactory block_rngs = rngs.child(static_cast<std::uint64_t>(sweep), static_cast<std::uint64_t>(b));
        double previous = std::numeric_limits<double>::quiet_NaN();
        for (std::size_t g = e; g < group_end; ++g) {
          const ScheduledMove& s = schedule.sweep[g];
          MoveRecord& r = summary.moves[record_of[g][b]];
          const bool held_back = !std::isnan(previous) && !(previous < s.run_if_previous_acceptance_below);
          if (!allowed(g) || held_back) {
            ++r.skipped;
            continue;
          }
          const double rate = s.kind == MoveKind::kIndependence ? m.independence(b, block_rngs)
                                                                : m.random_walk(b, block_rngs);
          if (s.kind == MoveKind::kIndependence) {
            ind_sum[b] += rate;
            ++ind_runs[b];
          } else {
            rw_sum[b] += rate;
            ++rw_runs[b];
          }
          record_run(r, rate);
          ran_in_group[g - e] = true;
          previous = rate;
        }
      }
      for (std::size_t g = e; g < group_end; ++g) runs_in_stage[g] += ran_in_group[g - e] ? 1 : 0;
      e = group_end;
    }
    summary.sweeps = sweep + 1;
    if (after_sweep) after_sweep(sweep);

    // How far has the cloud moved since the start? (weighted mean squared Mahalanobis jump / 2d)
    bool far_enough = true;
    for (std::size_t b = 0; b < nb; ++b) {
      const Eigen::Index d = blocks[b].dim;
      m.current.resize(d, P);
      model.get_block(static_cast<int>(b), m.current);
      const Eigen::MatrixXd whitened = m.cloud[b].matrixL().solve(m.current - m.start[b]);
      summary.jump[b] = (whitened.colwise().squaredNorm().array().transpose() * W).sum() / W.sum() /
                        (2.0 * static_cast<double>(d));
      far_enough = far_enough && summary.jump[b] >= schedule.jump_target;
    }
    if (summary.sweeps >= min_sweeps && far_enough) break;
  }
  for (std::size_t b = 0; b < nb; ++b)
    summary.acceptance[b] = rw_runs[b] > 0 ? rw_sum[b] / rw_runs[b] : (ind_runs[b] > 0 ? ind_sum[b] / ind_runs[b] : 0.0);
  summary.scale_factor = m.factor;
  return summary;
}

}  // namespace ssrfleet::smc
