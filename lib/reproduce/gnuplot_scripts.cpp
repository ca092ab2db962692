#include "reproduce/gnuplot_scripts.hpp"

#include <sstream>


namespace ssrfleet::reproduce {

namespace {

const char* kStyles =
    "set style line 1 lc rgb '#1f4e9c' lw 2 dt 1\n"
    "set style line 2 lc rgb '#1f4e9c' lw 2 dt 2\n"
    "set style line 3 lc rgb '#c0392b' lw 2 dt 1\n"
    "set style line 4 lc rgb '#c0392b' lw 2 dt 2\n"
    "set style line 5 lc rgb '#7f7f7f' pt 7 ps 0.35\n"
    "set grid lc rgb '#dddddd'\n"
    "set key outside top center horizontal\n";

std::string fig4() {
  return io::png_and_svg_script("fig4", std::string(kStyles) +
      "set title \"Fig. 4: observed impact factors at the 16 sensors (AS1)\"\n"
      "set xlabel 'position along the road (m)'\nset ylabel 'impact factor (-)'\n"
      "plot 'fig4_observed.csv' skip 1 using 3:4 with points ls 5 title 'observed IF (each truck)'\n");
}

std::string fig6() {
  return io::png_and_svg_script("fig6", std::string(kStyles) +
      "set title \"Fig. 6: fleet distribution of suspension stiffness k\"\n"
      "set xlabel 'suspension stiffness k (kN/m)'\nset ylabel 'probability density (1/(kN/m))'\n"
      "set style fill transparent solid 0.35 border lc rgb '#999999'\n"
      "plot 'fig6_histogram.csv' skip 1 using (stringcolumn(1) eq 'k' ? $2/1e3 : NaN):($4*1e3):($3/1e3) "
      "with boxes lc rgb '#bbbbbb' title 'true trucks (histogram)', \\\n"
      "     'fig6_distributions.csv' skip 1 using (stringcolumn(1) eq 'k' ? $2/1e3 : NaN):($3*1e3) with lines ls 1 "
      "title 'fitted (posterior mean density)', \\\n"
      "     '' skip 1 using (stringcolumn(1) eq 'k' ? $2/1e3 : NaN):($4*1e3) with lines ls 2 title 'fitted 95 % band', \\\n"
      "     '' skip 1 using (stringcolumn(1) eq 'k' ? $2/1e3 : NaN):($5*1e3) with lines ls 2 notitle, \\\n"
      "     '' skip 1 using (stringcolumn(1) eq 'k' ? $2/1e3 : NaN):($6*1e3) with lines ls 3 title 'Table 1 distribution'\n");
}

std::string fig7() {
  return io::png_and_svg_script("fig7", std::string(kStyles) +
      "set title \"Fig. 7: observed IFs with the fitted model's mean and 95 % prediction limits (AS1)\"\n"
      "set xlabel 'position along the road (m)'\nset ylabel 'impact factor (-)'\n"
      "plot 'fig4_observed.csv' skip 1 using 3:4 with points ls 5 title 'observed IF', \\\n"
      "     'fig7_prediction.csv' skip 1 using 2:3 with linespoints ls 1 pt 5 ps 0.6 title 'predicted mean', \\\n"
      "     '' skip 1 using 2:4 with lines ls 2 title '95 % prediction limits', \\\n"
      "     '' skip 1 using 2:5 with lines ls 2 notitle\n");
}

std::string fig8() {
  return io::png_and_svg_script("fig8", std::string(kStyles) +
      "set title \"Fig. 8: fit on sensors 1-10, prediction at sensors 11-16 (AS1)\"\n"
      "set xlabel 'position along the road (m)'\nset ylabel 'impact factor (-)'\n"
      "plot 'fig4_observed.csv' skip 1 using ($2 > 10 ? $3 : NaN):4 with points ls 5 title 'observed IF (not used in the fit)', \\\n"
      "     'fig8_prediction.csv' skip 1 using ($3 == 0 ? $2 : NaN):4 with linespoints ls 1 pt 5 ps 0.6 title 'predicted mean', \\\n"
      "     '' skip 1 using ($3 == 0 ? $2 : NaN):5 with lines ls 2 title '95 % prediction limits', \\\n"
      "     '' skip 1 using ($3 == 0 ? $2 : NaN):6 with lines ls 2 notitle, \\\n"
      "     '' skip 1 using ($3 == 0 ? $2 : NaN):9 with linespoints ls 3 pt 7 ps 0.6 title 'observed mean'\n");
}

std::string fig9(const std::string& road, const std::string& file) {
  return io::png_and_svg_script(file, std::string(kStyles) +
      "set title \"Fig. 9: " + road + ", a new fleet vs the prediction from the AS1 fit\"\n"
      "set xlabel 'position along the road (m)'\nset ylabel 'impact factor (-)'\n"
      "set style fill transparent solid 0.25 noborder\n"
      "plot '" + file + ".csv' skip 1 using 2:11:12 with filledcurves lc rgb '#1f4e9c' title '95 % band of the predicted mean', \\\n"
      "     '' skip 1 using 2:3 with linespoints ls 1 pt 5 ps 0.6 title 'predicted mean', \\\n"
      "     '' skip 1 using 2:4 with lines ls 2 title 'predicted 95 % limits', \\\n"
      "     '' skip 1 using 2:5 with lines ls 2 notitle, \\\n"
      "     '' skip 1 using 2:6 with linespoints ls 3 pt 7 ps 0.6 title 'new fleet: mean', \\\n"
      "     '' skip 1 using 2:7 with lines ls 4 title 'new fleet: 2.5 / 97.5 % quantiles', \\\n"
      "     '' skip 1 using 2:8 with lines ls 4 notitle, \\\n"
      "     '' skip 1 using 2:10 with lines lc rgb '#000000' lw 1 dt 3 title 'population mean (20000 trucks)'\n");
}

std::string evolution() {
  // evolution.csv: truck, ess, then mean, q025, q975, truth for K, sigma_k, Kt, sigma_kt, Z, sigma_z, sigma_if.
  const auto panel = [](const std::string& title, const std::string& ylabel, int col, const std::string& scale) {
    const auto c = [&](int k) { return "($" + std::to_string(k) + scale + ")"; };
    return "set title '" + title + "'\nset ylabel '" + ylabel + "'\n" +
           "plot 'evolution.csv' skip 1 using 1:" + c(col) + " with lines ls 1 title 'posterior mean', \\\n" +
           "     '' skip 1 using 1:" + c(col + 1) + " with lines ls 2 title '95 % interval', \\\n" +
           "     '' skip 1 using 1:" + c(col + 2) + " with lines ls 2 notitle, \\\n" +
           "     '' skip 1 using 1:" + c(col + 3) + " with lines ls 3 title 'truth'\n";
  };
  return io::png_and_svg_script("evolution", std::string(kStyles) +
      "set multiplot layout 3,1 title 'Posterior after each truck (SMC; the batch MCMC has no such history)'\n"
      "set xlabel 'trucks absorbed'\n" +
      panel("fleet mean suspension stiffness K", "K (kN/m)", 3, "/1e3") +
      panel("fleet mean tyre stiffness K_t", "K_t (kN/m)", 11, "/1e3") +
      panel("fleet mean lateral position Z", "Z (m)", 19, "") + "unset multiplot\n",
      900, 1000);
}

}  // namespace

std::vector<PlotScript> plot_scripts() {
  return {{"fig4", fig4()},           {"fig6", fig6()},
          {"fig7", fig7()},           {"fig8", fig8()},
          {"fig9_as2", fig9("AS2", "fig9_as2")}, {"fig9_as3", fig9("AS3", "fig9_as3")},
          {"evolution", evolution()}};
}

}  // namespace ssrfleet::reproduce
