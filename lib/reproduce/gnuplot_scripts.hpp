// gnuplot scripts for the reproduction's figures. Each script reads the CSVs that
// paper_reproduction writes (same folder) and renders one figure as PNG (pngcairo, or the plain
// png terminal) and SVG, in the paper's style: mean solid, 95 % limits dashed.
#pragma once

#include <string>
#include <vector>

namespace ssrfleet::reproduce {

struct PlotScript {
  std::string name;    // file stem: fig7 -> fig7.gp, fig7.png, fig7.svg
  std::string script;  // the .gp text
};

// The scripts for fig4, fig6 (k), fig7, fig8, fig9 (AS2, AS3) and the evolution.
std::vector<PlotScript> plot_scripts();

// True if an executable `gnuplot` is on PATH.
bool gnuplot_available();

// Runs `gnuplot NAME.gp` in `dir` for each script; returns the names that failed.
std::vector<std::string> run_gnuplot(const std::string& dir, const std::vector<PlotScript>& scripts);

}  // namespace ssrfleet::reproduce
