#include "fleet/batch_mcmc_chains.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <thread>

#include "smc/rng.hpp"
#include "util/errors.hpp"
#include "util/option_rules.hpp"
#include "util/stop_token.hpp"

namespace ssrfleet::fleet {

bool BatchMcmcChainsOptions::IsValid(std::string* error) const {
  util::OptionRules rules("BatchMcmcChainsOptions", error);
  rules.require(chains >= 1 && chains <= 64, "chains", chains, "in [1, 64]");
  rules.require(start_dispersion >= 0.0 && start_dispersion <= 10.0, "start_dispersion", start_dispersion, "in [0, 10]");
  std::string chain_error;
  rules.nested(chain.IsValid(&chain_error), chain_error);
  return rules.passed();
}

std::uint64_t chain_seed(std::uint64_t seed, int chain) {
  if (chain == 0) return seed;
  return smc::RngFactory(seed).child(0x636861696eULL /* "chain" */, static_cast<std::uint64_t>(chain)).key();
}

std::vector<BatchMcmcResult> run_batch_mcmc_chains(const site::Site& site, const std::vector<records::WimRecord>& records,
                                                   const BatchMcmcChainsOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw UsageError(why);
  const int threads = options.chain.threads > 0 ? options.chain.threads
                                                : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int together = std::min(options.chains, threads);
  std::vector<BatchMcmcResult> out(static_cast<std::size_t>(options.chains));
  std::vector<std::exception_ptr> failed(out.size());
  for (int first = 0; first < options.chains; first += together) {
    const int last = std::min(options.chains, first + together);
    std::vector<std::thread> running;
    for (int c = first; c < last; ++c) {
      BatchMcmcOptions o = options.chain;
      o.seed = chain_seed(options.chain.seed, c);
      o.start_dispersion = c == 0 ? options.chain.start_dispersion : options.start_dispersion;
      // Each chain its share of the threads (the first ones take the remainder).
      o.threads = threads / (last - first) + (c - first < threads % (last - first) ? 1 : 0);
      // Progress from the first chain alone: the chains run side by side.
      if (c != 0) o.progress = nullptr;
      running.emplace_back([&, o, c, stop = util::current_stop_token()] {
        const util::StopScope driver(stop);  // the chain's thread drives it: the caller's token
        try {
          out[static_cast<std::size_t>(c)] = run_batch_mcmc(site, records, o);
        } catch (...) {
          failed[static_cast<std::size_t>(c)] = std::current_exception();
        }
      });
    }
    for (auto& t : running) t.join();
    for (const auto& e : failed)
      if (e) std::rethrow_exception(e);
  }
  return out;
}

std::vector<ParameterConvergence> chain_convergence(const std::vector<BatchMcmcResult>& chains,
                                                    const ModelExtension* extension) {
  std::vector<ParameterConvergence> out;
  if (chains.empty()) return out;
  const Eigen::Index draws = chains.front().theta_draws.rows();
  for (const auto& c : chains)
    if (c.theta_draws.rows() != draws) throw std::logic_error("chain_convergence: chains of different lengths");
  const auto C = static_cast<Eigen::Index>(chains.size());
  auto summarise = [&](const std::string& name, auto column_of) {
    Eigen::MatrixXd m(draws, C);
    for (Eigen::Index c = 0; c < C; ++c) m.col(c) = column_of(chains[static_cast<std::size_t>(c)]);
    const util::ConvergenceSummary s = util::summarise_convergence(m);
    out.push_back({name, s.rhat, s.ess_bulk, s.ess_tail, s.mcse_mean, s.mcse_q05, s.mcse_q95});
  };
  for (int j = 0; j < kHyperCount; ++j)
    summarise(std::string(kHyperNames[static_cast<std::size_t>(j)]), [j](const BatchMcmcResult& r) { return r.theta_draws.col(j); });
  if (extension != nullptr) {
    const auto& params = extension->parameters();
    for (std::size_t j = 0; j < params.size(); ++j) {
      summarise(params[j].name, [j](const BatchMcmcResult& r) { return r.psi_draws.col(static_cast<Eigen::Index>(j)); });
    }
  }
  return out;
}

PosteriorCloud to_posterior_cloud(const std::vector<BatchMcmcResult>& chains, const site::Site& site,
                                  const std::vector<records::WimRecord>& records, const ModelExtension* extension) {
  if (chains.size() == 1) return to_posterior_cloud(chains.front(), site, records, extension);
  BatchMcmcResult pooled = chains.front();
  Eigen::Index rows = 0;
  for (const auto& c : chains) rows += c.theta_draws.rows();
  pooled.theta_draws.resize(rows, chains.front().theta_draws.cols());
  pooled.psi_draws.resize(rows, chains.front().psi_draws.cols());
  Eigen::Index at = 0;
  for (const auto& c : chains) {
    pooled.theta_draws.middleRows(at, c.theta_draws.rows()) = c.theta_draws;
    if (pooled.psi_draws.cols() > 0) pooled.psi_draws.middleRows(at, c.psi_draws.rows()) = c.psi_draws;
    at += c.theta_draws.rows();
  }
  PosteriorCloud cloud = to_posterior_cloud(pooled, site, records, extension);
  cloud.chains = static_cast<int>(chains.size());
  cloud.convergence = chain_convergence(chains, extension);
  double ess = std::numeric_limits<double>::infinity();
  for (int j = 0; j < kHyperCount; ++j) {
    const double e = cloud.convergence[static_cast<std::size_t>(j)].ess_bulk;
    if (!std::isnan(e)) ess = std::min(ess, e);  // a pinned box edge says nothing
  }
  cloud.min_ess = std::isfinite(ess) ? ess : static_cast<double>(rows);
  return cloud;
}

}  // namespace ssrfleet::fleet
