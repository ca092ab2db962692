#include "io/draws_csv.hpp"

#include <stdexcept>

#include "model/fleet_model.hpp"
#include "road/road_file.hpp"

namespace ssrfleet::io {

std::vector<std::string> draws_csv_columns(const std::vector<std::string>& psi_names) {
  std::vector<std::string> columns = {"chain", "draw"};
  for (const auto& name : fleet::kHyperNames) columns.emplace_back(name);
  columns.insert(columns.end(), psi_names.begin(), psi_names.end());
  return columns;
}

void write_draws_csv(std::ostream& out, const fleet::EqualWeightDraws& draws,
                     const std::vector<std::string>& psi_names) {
  if (psi_names.size() != static_cast<std::size_t>(draws.psi.rows())) {
    throw std::invalid_argument("io::write_draws_csv(): " + std::to_string(psi_names.size()) + " names for " +
                                std::to_string(draws.psi.rows()) + " extension parameters");
  }
  const auto columns = draws_csv_columns(psi_names);
  for (std::size_t i = 0; i < columns.size(); ++i) out << (i ? "," : "") << columns[i];
  out << "\n";
  for (int c = 0; c < draws.chains; ++c) {
    for (Eigen::Index d = 0; d < draws.draws; ++d) {
      const Eigen::Index col = c * draws.draws + d;
      out << c << ',' << d;
      for (int h = 0; h < fleet::kHyperCount; ++h) out << ',' << road::shortest_decimal(draws.theta(h, col));
      for (Eigen::Index k = 0; k < draws.psi.rows(); ++k)
        out << ',' << road::shortest_decimal(draws.psi(k, col));
      out << '\n';
    }
  }
}

}  // namespace ssrfleet::io
