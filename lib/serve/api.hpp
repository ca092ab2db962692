// The JSON API's answers (docs/serve.md lists every path, parameter and unit). Each takes the state
// and the parsed query and returns a status and a body; a bad parameter is a QueryError the server
// turns into a 400. Everything about the latest checkpoint comes from one snapshot; what needs
// simulation goes through the computation worker and says which checkpoint it was computed at.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "serve/computations.hpp"
#include "serve/query.hpp"
#include "serve/served_state.hpp"

namespace ssrfleet::serve {

struct ApiResponse {
  int status = 200;
  nlohmann::json body;
};

// The unit of a hyperparameter of the base model ("" for an effect's parameter: see ssrfleet effects).
std::string hyperparameter_unit(const std::string& name);

nlohmann::json api_states(const std::vector<std::unique_ptr<ServedState>>& states);
ApiResponse api_summary(ServedState& state, const Query& q, double now_s, double idle_after_s);
ApiResponse api_history(ServedState& state, const Query& q);
ApiResponse api_rejects(ServedState& state, const Query& q);
// The SSR along the array: from the snapshot (the history's prediction at the first site's sensors)
// unless positions, a class or another site are asked for, then from the worker.
ApiResponse api_ssr(ServedState& state, std::size_t state_index, const Query& q, Computations& computations);
ApiResponse api_damage(ServedState& state, std::size_t state_index, const Query& q,
                       Computations& computations);

}  // namespace ssrfleet::serve
