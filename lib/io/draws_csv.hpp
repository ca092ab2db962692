// The draws CSV (docs/draws.md): a posterior's equal-weight draws (fleet/equal_weight_draws.hpp), one
// row a draw, for numpy, pandas or R. Header
//   chain,draw,K,sigma_k,Kt,sigma_kt,Z,sigma_z,sigma_if[,psi names...]
// chain and draw count from 0 (chain-major, as ArviZ's dims (chain, draw)); the hyperparameters in
// fleet_model.hpp order and units (N/m for K, sigma_k, Kt, sigma_kt; m for Z, sigma_z; sigma_if has
// none), then the model's free parameters by their names, in their units. Numbers are the shortest
// decimals that read back to the same doubles, so a reader gets the posterior file's values exactly.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "fleet/equal_weight_draws.hpp"

namespace ssrfleet::io {

// The header's names, in column order.
std::vector<std::string> draws_csv_columns(const std::vector<std::string>& psi_names);

// psi_names: one per row of draws.psi (std::invalid_argument otherwise).
void write_draws_csv(std::ostream& out, const fleet::EqualWeightDraws& draws,
                     const std::vector<std::string>& psi_names);

}  // namespace ssrfleet::io
