// Resampling schemes (Douc, Cappé & Moulines 2005; particles' resampling.py). Each turns
// normalised weights W (size P, sum 1) into M ancestor indices with E[#offspring of i] = M W_i,
// in non-decreasing order, using one generator, so a fixed seed gives fixed ancestors.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "smc/rng.hpp"

namespace ssrfleet::smc {

enum class ResamplingScheme {
  systematic,   // one uniform, M evenly spaced points: lowest variance in practice (default)
  stratified,   // one uniform per stratum [k/M, (k+1)/M)
  multinomial,  // M independent draws (sorted uniforms from exponential spacings, O(M + P))
  residual,     // floor(M W_i) copies kept, the remainder drawn multinomially
};

std::string_view to_string(ResamplingScheme scheme);
// "systematic", "stratified", "multinomial" or "residual"; UsageError otherwise.
ResamplingScheme resampling_scheme_from_string(std::string_view name);

std::vector<Eigen::Index> resample(ResamplingScheme scheme, const Eigen::Ref<const Eigen::ArrayXd>& W,
                                   Eigen::Index M, Rng& rng);

std::vector<Eigen::Index> systematic_resampling(const Eigen::Ref<const Eigen::ArrayXd>& W, Eigen::Index M, Rng& rng);
std::vector<Eigen::Index> stratified_resampling(const Eigen::Ref<const Eigen::ArrayXd>& W, Eigen::Index M, Rng& rng);
std::vector<Eigen::Index> multinomial_resampling(const Eigen::Ref<const Eigen::ArrayXd>& W, Eigen::Index M, Rng& rng);
std::vector<Eigen::Index> residual_resampling(const Eigen::Ref<const Eigen::ArrayXd>& W, Eigen::Index M, Rng& rng);

}  // namespace ssrfleet::smc
