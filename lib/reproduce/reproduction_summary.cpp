#include "reproduce/reproduction_summary.hpp"

#include <algorithm>
#include <array>

#include "reproduce/number_text.hpp"

namespace ssrfleet::reproduce {

void write_summary_markdown(std::ostream& os, const Options& o, const Result& res, std::size_t history_trucks) {
  const auto& h = res.hyper;
  os << "# ssrfleet reproduce: Wilson, Harris & O'Brien, theoretical test (§4)\n\n"
     << "Configuration: " << o.trucks << " Table 1 trucks on AS1, 16 sensors at 76.0-98.5 m, noise sd sigma_IF = "
     << fmt(o.noise_sd) << ", seed " << o.seed << ", SMC with " << o.particles << " particles streaming one truck at a time, "
     << "prediction from " << o.theta_draws << " posterior draws x " << o.trucks_per_draw << " trucks. "
     << "Every value in the measured column comes from this run; the paper's column quotes the paper.\n\n"
     << "| figure | quantity | measured (this run) | paper (Wilson et al.) |\n|---|---|---|---|\n";
  os << "| Fig. 4 | observed IF range over " << o.trucks << " trucks x 16 sensors | " << fixed(res.observed_if_min, 3)
     << " to " << fixed(res.observed_if_max, 3) << " (sd " << fixed(res.observed_dlc, 3)
     << ") | observed impact factors at the sixteen WIM locations for each of the 100 vehicles |\n";
  const std::array<const char*, fleet::kHyperCount> label = {"K (N/m)", "sigma_k (N/m)", "K_t (N/m)", "sigma_kt (N/m)",
                                                             "Z (m)", "sigma_z (m)", "sigma_IF"};
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    const bool in = res.truth[j] >= h[j].q025 && res.truth[j] <= h[j].q975;
    os << "| Fig. 6 | " << label[j] << ": posterior mean [95 % interval] (truth) | " << fmt(h[j].mean) << " ["
       << fmt(h[j].q025) << ", " << fmt(h[j].q975) << "] (" << fmt(res.truth[j]) << ", "
       << (in ? "inside" : "outside") << ") | "
       << (j == fleet::kK ? "good agreement between inferred and true distributions of k"
                          : "similar results for k_t and z (no hyperparameter values given)")
       << " |\n";
  }
  os << "| Fig. 6 | truths inside their 95 % interval | " << res.hyper_covered << " of " << int(fleet::kHyperCount)
     << " | not reported |\n";
  os << "| Fig. 7 | observed IFs inside the 95 % prediction limits | " << pct(res.fig7_coverage)
     << " | approximately 97 % |\n";
  os << "| Fig. 8 | observed IFs at sensors 11-16 inside the limits (fit on sensors 1-10) | " << pct(res.fig8_coverage)
     << " | effective in predicting the range of observed impact factors |\n";
  os << "| Fig. 8 | highest-mean sensor among 11-16: predicted / observed | sensor " << res.fig8_predicted_peak
     << " / sensor " << res.fig8_observed_peak << " ("
     << (res.fig8_predicted_peak == res.fig8_observed_peak ? "correct" : "wrong")
     << ") | sensors 12 and 13 (92.5 m, 94 m) predicted correctly as high-mean locations |\n";
  os << "| Fig. 8 | two highest-mean sensors among 11-16: predicted / observed | " << res.fig8_predicted_top2[0] << " and "
     << res.fig8_predicted_top2[1] << " / " << res.fig8_observed_top2[0] << " and " << res.fig8_observed_top2[1] << " ("
     << (res.fig8_predicted_top2 == res.fig8_observed_top2 ? "same" : "different")
     << ") | sensors 12 and 13 will be locations of high mean impact factor |\n";
  os << "| Fig. 8 | largest abs. difference of mean IF at 11-16, predicted vs observed | " << fixed(res.fig8_max_mean_diff, 4)
     << " | the fitted model predicts the pattern of SSR |\n";
  for (const auto& c : res.fig9) {
    os << "| Fig. 9 | " << c.road << ": largest abs. difference of mean IF, predicted vs new fleet | "
       << fixed(c.max_abs_mean_diff, 4) << " (sensor " << c.max_mean_sensor << ") | "
       << (c.road == "AS2" ? "excellent agreement for mean impact factors and 95 % limits" : "similar agreement for AS3")
       << " |\n";
    os << "| Fig. 9 | " << c.road << ": largest abs. difference of mean IF, predicted vs the true fleet's population mean (20000 trucks) | "
       << fixed(c.max_abs_population_diff, 4) << " | (not in the paper: separates inference error from the new fleet's sampling error) |\n";
    os << "| Fig. 9 | " << c.road << ": widest 95 % band of the predicted mean (half-width); sensors whose band holds the population mean | "
       << fixed(c.max_band_half_width, 4) << "; " << c.band_covers_population << " of " << c.sensors
       << " | (not in the paper: how precisely the AS1 fit fixes the mean on this road) |\n";
    os << "| Fig. 9 | " << c.road << ": largest abs. difference of mean IF, population mean vs new fleet | "
       << fixed(c.max_abs_oracle_diff, 4) << " | (not in the paper: what a perfect predictor would miss by) |\n";
    os << "| Fig. 9 | " << c.road << ": largest abs. difference of a 95 % limit | " << fixed(c.max_abs_limit_diff, 4)
       << " | (no number given) |\n";
    os << "| Fig. 9 | " << c.road << ": new fleet's observed IFs inside the predicted limits | " << pct(c.coverage)
       << " | (no number given) |\n";
  }
  const std::size_t n = history_trucks;
  os << "| evolution | 95 % interval width of K after " << std::max<std::size_t>(1, n / 10) << " / "
     << std::max<std::size_t>(1, n / 2) << " / " << n << " trucks (N/m) | " << fmt(res.k_interval_width[0], 3) << " / "
     << fmt(res.k_interval_width[1], 3) << " / " << fmt(res.k_interval_width[2], 3)
     << " | not available: batch MCMC gives one posterior |\n";
  os << "| run | wall time: SMC fit / whole reproduction | " << fixed(res.fit_wall_s, 1) << " s / "
     << fixed(res.total_wall_s, 1) << " s | MATLAB/Simulink, no time reported |\n";
  os << "\nFiles: fig4_observed.csv, fig6_distributions.csv, fig6_histogram.csv, fig6_hyperparameters.csv, "
        "fig7_prediction.csv, fig8_prediction.csv, fig9_as2.csv, fig9_as3.csv, evolution.csv; gnuplot scripts *.gp"
     << (res.plotted ? " and their PNG/SVG renderings" : " (gnuplot was not run: `gnuplot fig7.gp` renders one)") << ".\n";
}

}  // namespace ssrfleet::reproduce
