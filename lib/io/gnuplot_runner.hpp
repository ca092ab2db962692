// Renders plots with gnuplot when it is installed: each script is written beside the CSVs it
// reads and run in that folder. Commands write the data and scripts regardless, so a machine
// without gnuplot still gets everything needed to plot later.
#pragma once

#include <string>
#include <vector>

namespace ssrfleet::io {

struct PlotScript {
  std::string name;    // file stem: fig7 -> fig7.gp, fig7.png, fig7.svg
  std::string script;  // the .gp text
};

// A complete script that renders `body` (gnuplot commands ending in a plot) twice: NAME.png
// (pngcairo when present, else the plain png terminal) and NAME.svg; CSV input (separator ',').
std::string png_and_svg_script(const std::string& name, const std::string& body, int width = 900, int height = 600);

// True if an executable `gnuplot` is on PATH.
bool gnuplot_available();

// Runs `gnuplot NAME.gp` in `dir` for each script; returns the names that failed (their error
// output is left in NAME.gnuplot.log).
std::vector<std::string> run_gnuplot(const std::string& dir, const std::vector<PlotScript>& scripts);

}  // namespace ssrfleet::io
