// gnuplot scripts for the reproduction's figures. Each script reads the CSVs that
// paper_reproduction writes (same folder) and renders one figure as PNG (pngcairo, or the plain
// png terminal) and SVG, in the paper's style: mean solid, 95 % limits dashed.
#pragma once

#include <string>
#include <vector>

#include "io/gnuplot_runner.hpp"

namespace ssrfleet::reproduce {

using io::PlotScript;

// The scripts for fig4, fig6 (k), fig7, fig8, fig9 (AS2, AS3) and the evolution.
std::vector<PlotScript> plot_scripts();

}  // namespace ssrfleet::reproduce
