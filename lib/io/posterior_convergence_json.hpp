// The posterior file's optional convergence fields (docs/outputs.md): "chains", the number of
// independent runs pooled in the draws (MCMC chains or SMC runs), and "convergence", per parameter
// R̂, bulk- and tail-ESS, the Monte Carlo standard errors of the mean and of the 5 % and 95 %
// quantiles, and for SMC runs the equivalent ESS (fleet::ParameterConvergence). Written only for
// several runs; a file without them is one chain's or one SMC run's.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "fleet/posterior_cloud.hpp"

namespace ssrfleet::io {

void write_convergence(const fleet::PosteriorCloud& cloud, nlohmann::json& j);
// DataError naming path and the field (prefixed by P) if present and malformed.
void read_convergence(const nlohmann::json& j, const std::string& path, const std::string& P, fleet::PosteriorCloud& cloud);

}  // namespace ssrfleet::io
