#include "reproduce/paper_reproduction.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "fleet/online_fit.hpp"
#include "fleet/replay.hpp"
#include "fleet/simulator.hpp"
#include "io/atomic_file.hpp"
#include "io/posterior_json.hpp"
#include "model/fleet_distribution.hpp"
#include "model/model_spec.hpp"
#include "predict/ssr_prediction.hpp"
#include "reproduce/gnuplot_scripts.hpp"
#include "reproduce/number_text.hpp"
#include "reproduce/reproduction_summary.hpp"
#include "site/road_source.hpp"
#include "smc/engine.hpp"
#include "util/errors.hpp"
#include "util/quantile.hpp"

namespace ssrfleet::reproduce {

void Options::validate() const {
  if (trucks < 2 || trucks > 100000) throw UsageError("--trucks " + std::to_string(trucks) + ": must be between 2 and 100000");
  if (particles < 2) throw UsageError("--particles " + std::to_string(particles) + ": must be >= 2");
  if (threads < 0) throw UsageError("--threads " + std::to_string(threads) + ": must be >= 0");
  if (!(noise_sd > 0.0) || !(noise_sd <= 1.0)) {
    throw UsageError("--noise " + std::to_string(noise_sd) + ": must be in (0, 1] (the fit's prior on sigma_IF)");
  }
  if (theta_draws < 2 || trucks_per_draw < 1) throw UsageError("prediction draws: need >= 2 theta draws and >= 1 truck per draw");
  if (out_dir.empty()) throw UsageError("--out: empty folder name");
}

namespace {
// Fig. 9's population reference: trucks drawn from the true fleet distribution.
constexpr int kPopulationTrucks = 20000;

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }


struct Writer {
  std::string dir;
  std::vector<std::string>* files;
  void operator()(const std::string& name, const std::function<void(std::ostream&)>& write) const {
    io::write_file_atomically((std::filesystem::path(dir) / name).string(), [&](std::ostream& os) {
      os << std::setprecision(10);
      write(os);
    });
    files->push_back(name);
  }
};

fleet::PosteriorCloud stream_fit(const site::Site& site, const std::vector<records::WimRecord>& records, const Options& o,
                                 const std::string& label,
                                 const std::function<void(std::size_t, const fleet::OnlineFit&)>& after_each) {
  fleet::OnlineFitOptions so;  // the core `fit` chooses for the model
  const fleet::ModelSpec model = fleet::parse_model_spec(o.model, site);
  so.core = fleet::choose_core(model.extension.get());
  so.extension = model.extension.get();
  so.sampler().particles = o.particles;
  so.sampler().threads = o.threads > 0 ? o.threads : smc::TemperedSampler::Options::default_threads();
  so.sampler().seed = o.seed;
  std::string why;
  if (!so.sampler().IsValid(&why)) throw UsageError(why);
  const auto fit = fleet::make_online_fit(site, so);
  const auto start = Clock::now();
  const std::size_t every = records.size() <= 20 ? 1 : 10;
  fleet::ReplayOptions replay;  // the same final sweeps as `fit`: a posterior of the same quality
  replay.after_record = [&](std::size_t t, const smc::StageSummary&, const fleet::OnlineFit& smc) {
    if (after_each) after_each(t, smc);
    if (o.progress && ((t + 1) % every == 0 || t + 1 == records.size())) {
      *o.progress << "reproduce: " << label << ": truck " << (t + 1) << "/" << records.size() << ", ESS "
                  << std::fixed << std::setprecision(0) << smc.sampler().ess() << "/" << o.particles << ", "
                  << std::setprecision(1) << seconds_since(start) << " s\n"
                  << std::defaultfloat;
    }
  };
  fleet::replay(*fit, records, replay);
  return fit->cloud();
}

std::array<fleet::ParameterSummary, fleet::kHyperCount> summarise(const fleet::PosteriorCloud& c) {
  const auto v = fleet::summarise_weighted(c.theta, c.weights);
  std::array<fleet::ParameterSummary, fleet::kHyperCount> a{};
  std::copy(v.begin(), v.end(), a.begin());
  return a;
}

// Share of observed IFs (rows of records, sensors [from, to)) inside the prediction's limits at
// prediction index (m - from + offset).
double coverage(const std::vector<records::WimRecord>& records, const predict::SsrPrediction& p, int from, int to,
                int pred_offset) {
  long in = 0, all = 0;
  for (const auto& r : records) {
    for (int m = from; m < to; ++m) {
      const Eigen::Index j = m - from + pred_offset;
      const double y = r.impact_factor[m];
      in += (y >= p.lower95[j] && y <= p.upper95[j]) ? 1 : 0;
      ++all;
    }
  }
  return all ? static_cast<double>(in) / static_cast<double>(all) : 0.0;
}

Eigen::ArrayXd observed_mean(const std::vector<records::WimRecord>& records, int sensors) {
  Eigen::ArrayXd m = Eigen::ArrayXd::Zero(sensors);
  for (const auto& r : records) m += r.impact_factor.head(sensors).array();
  return m / static_cast<double>(records.size());
}

double normal_pdf(double x, double mean, double sd) {
  return std::exp(fleet::log_normal_density(x, mean, sd));
}

}  // namespace

Result run(const Options& o) {
  o.validate();
  const auto t0 = Clock::now();
  Result res;
  std::filesystem::create_directories(o.out_dir);
  const Writer write{o.out_dir, &res.files};
  auto say = [&](const std::string& line) {
    if (o.progress) *o.progress << "reproduce: " << line << "\n";
  };

  // The paper's theoretical test: Table 1 fleet on AS1, 16 sensors.
  const fleet::FleetDistribution dist;
  const site::Site site(site::load_road("AS1"), site::SiteOptions{});
  const int M = site.sensors();
  const auto trucks = fleet::draw_fleet(dist, o.trucks, site.lateral_min_m(), site.lateral_max_m(), o.seed);
  const fleet::SimulationModel hidden = fleet::parse_simulation_model(o.effect, site);
  fleet::parse_model_spec(o.model, site);  // a bad model fails here, before the work
  const auto log = hidden.extension ? fleet::simulate_log(site, trucks, o.noise_sd, o.seed, *hidden.extension, hidden.psi)
                                    : fleet::simulate_log(site, trucks, o.noise_sd, o.seed);
  const auto& records = log.records;
  if (hidden.extension || o.model != "base") say("data with " + (hidden.extension ? hidden.text : std::string("no effect")) +
                                                 ", fitted with model " + o.model);
  say(std::to_string(trucks.size()) + " Table 1 trucks on AS1 (" + std::to_string(M) + " sensors), noise sd " +
      fmt(o.noise_sd) + ", seed " + std::to_string(o.seed) + ", " + std::to_string(o.particles) + " particles -> " +
      o.out_dir);
  res.truth = {dist.stiffness_npm.mean, dist.stiffness_npm.sd, dist.tyre_stiffness_npm.mean, dist.tyre_stiffness_npm.sd,
               dist.lateral_m.mean,     dist.lateral_m.sd,     o.noise_sd};

  // Fig. 4: observed IFs.
  {
    double lo = 1e300, hi = -1e300, sum = 0.0, sum2 = 0.0;
    long n = 0;
    for (const auto& r : records) {
      for (int m = 0; m < M; ++m) {
        const double y = r.impact_factor[m];
        lo = std::min(lo, y), hi = std::max(hi, y), sum += y, sum2 += y * y, ++n;
      }
    }
    res.observed_if_min = lo, res.observed_if_max = hi;
    const double mean = sum / n;
    res.observed_dlc = std::sqrt(std::max(0.0, (sum2 - n * mean * mean) / (n - 1)));
    write("fig4_observed.csv", [&](std::ostream& os) {
      os << "truck_id,sensor,position_m,observed_if,model_if\n";
      for (std::size_t t = 0; t < records.size(); ++t) {
        for (int m = 0; m < M; ++m) {
          os << records[t].truck_id << ',' << (m + 1) << ',' << site.sensor_positions_m()[static_cast<std::size_t>(m)]
             << ',' << records[t].impact_factor[m] << ',' << log.model_if(m, static_cast<Eigen::Index>(t)) << '\n';
        }
      }
    });
  }

  // The streamed fit, with the posterior after every truck.
  std::vector<std::array<fleet::ParameterSummary, fleet::kHyperCount>> history;
  std::vector<double> ess_history;
  const auto fit_start = Clock::now();
  const auto cloud = stream_fit(site, records, o, "fit on AS1 (16 sensors)", [&](std::size_t, const fleet::OnlineFit& smc) {
    const Eigen::ArrayXd w = smc.sampler().weights();
    const auto v = fleet::summarise_weighted(smc.cloud().theta, w);
    std::array<fleet::ParameterSummary, fleet::kHyperCount> a{};
    std::copy(v.begin(), v.end(), a.begin());
    history.push_back(a);
    ess_history.push_back(smc.sampler().ess());
  });
  res.fit_wall_s = seconds_since(fit_start);
  res.hyper = summarise(cloud);
  // The fit's posterior, with its model, ready for predict.
  write("posterior.json", [&](std::ostream& os) {
    os << io::posterior_file_text(io::posterior_to_json(cloud, fleet::summarise_cloud(cloud), fleet::summarise_psi(cloud)));
  });
  for (int j = 0; j < fleet::kHyperCount; ++j) {
    res.hyper_covered += (res.truth[j] >= res.hyper[j].q025 && res.truth[j] <= res.hyper[j].q975) ? 1 : 0;
  }
  {
    const std::size_t n = history.size();
    const std::array<std::size_t, 3> at = {std::max<std::size_t>(1, n / 10), std::max<std::size_t>(1, n / 2), n};
    for (int i = 0; i < 3; ++i) {
      const auto& s = history[at[i] - 1][fleet::kK];
      res.k_interval_width[i] = s.q975 - s.q025;
    }
  }
  write("evolution.csv", [&](std::ostream& os) {
    os << "truck,ess";
    for (auto name : fleet::kHyperNames) os << ',' << name << "_mean," << name << "_q025," << name << "_q975," << name << "_truth";
    os << '\n';
    for (std::size_t t = 0; t < history.size(); ++t) {
      os << (t + 1) << ',' << ess_history[t];
      for (int j = 0; j < fleet::kHyperCount; ++j) {
        os << ',' << history[t][j].mean << ',' << history[t][j].q025 << ',' << history[t][j].q975 << ',' << res.truth[j];
      }
      os << '\n';
    }
  });

  // Fig. 6: hyperparameters, and the fleet densities of k, k_t, z.
  write("fig6_hyperparameters.csv", [&](std::ostream& os) {
    os << "name,mean,sd,q025,q975,truth,covered\n";
    for (int j = 0; j < fleet::kHyperCount; ++j) {
      const auto& s = res.hyper[j];
      const bool in = res.truth[j] >= s.q025 && res.truth[j] <= s.q975;
      os << fleet::kHyperNames[j] << ',' << s.mean << ',' << s.sd << ',' << s.q025 << ',' << s.q975 << ','
         << res.truth[j] << ',' << (in ? 1 : 0) << '\n';
    }
  });
  {
    struct Var {
      const char* name;
      fleet::Hyper mean, sd;
      double lo, hi;
      bool truncated;
      double (*value)(const records::Truck&);
    };
    const std::array<Var, 3> vars = {{
        {"k", fleet::kK, fleet::kSigmaK, dist.stiffness_npm.mean - 4 * dist.stiffness_npm.sd,
         dist.stiffness_npm.mean + 4 * dist.stiffness_npm.sd, false, [](const records::Truck& t) { return t.stiffness_npm; }},
        {"kt", fleet::kKt, fleet::kSigmaKt, dist.tyre_stiffness_npm.mean - 4 * dist.tyre_stiffness_npm.sd,
         dist.tyre_stiffness_npm.mean + 4 * dist.tyre_stiffness_npm.sd, false,
         [](const records::Truck& t) { return t.tyre_stiffness_npm; }},
        {"z", fleet::kZ, fleet::kSigmaZ, site.lateral_min_m(), site.lateral_max_m(), true,
         [](const records::Truck& t) { return t.lateral_m; }},
    }};
    const std::array<fleet::Normal, 3> true_dist = {dist.stiffness_npm, dist.tyre_stiffness_npm, dist.lateral_m};
    const int G = 161, bins = 16;
    const Eigen::Index P = cloud.theta.cols();
    write("fig6_distributions.csv", [&](std::ostream& os) {
      os << "variable,value,posterior_density,density_q025,density_q975,true_density\n";
      for (std::size_t v = 0; v < vars.size(); ++v) {
        const auto& var = vars[v];
        Eigen::ArrayXd norm = Eigen::ArrayXd::Ones(P);
        if (var.truncated) {
          for (Eigen::Index p = 0; p < P; ++p) {
            norm[p] = std::exp(fleet::log_normal_mass(var.lo, var.hi, cloud.theta(var.mean, p), cloud.theta(var.sd, p)));
          }
        }
        const double true_norm =
            var.truncated ? std::exp(fleet::log_normal_mass(var.lo, var.hi, true_dist[v].mean, true_dist[v].sd)) : 1.0;
        Eigen::VectorXd dens(P);
        for (int g = 0; g < G; ++g) {
          const double x = var.lo + (var.hi - var.lo) * g / (G - 1);
          for (Eigen::Index p = 0; p < P; ++p) {
            dens[p] = normal_pdf(x, cloud.theta(var.mean, p), cloud.theta(var.sd, p)) / norm[p];
          }
          const Eigen::VectorXd w = cloud.weights.matrix();
          os << var.name << ',' << x << ',' << dens.dot(w) / w.sum() << ','
             << fleet::weighted_quantile(dens, w, 0.025) << ',' << fleet::weighted_quantile(dens, w, 0.975) << ','
             << normal_pdf(x, true_dist[v].mean, true_dist[v].sd) / true_norm << '\n';
        }
      }
    });
    write("fig6_histogram.csv", [&](std::ostream& os) {
      os << "variable,bin_centre,bin_width,density\n";
      for (const auto& var : vars) {
        const double width = (var.hi - var.lo) / bins;
        std::vector<int> count(bins, 0);
        for (const auto& t : trucks) {
          const int b = static_cast<int>(std::floor((var.value(t) - var.lo) / width));
          if (b >= 0 && b < bins) ++count[static_cast<std::size_t>(b)];
        }
        for (int b = 0; b < bins; ++b) {
          os << var.name << ',' << var.lo + (b + 0.5) * width << ',' << width << ','
             << count[static_cast<std::size_t>(b)] / (static_cast<double>(trucks.size()) * width) << '\n';
        }
      }
    });
  }

  predict::PredictionOptions popts;
  popts.theta_draws = o.theta_draws;
  popts.trucks_per_draw = o.trucks_per_draw;
  popts.seed = o.seed;

  // Fig. 7: prediction at the sensors against the observed IFs.
  say("predicting the SSR pattern at the 16 sensors (Fig. 7)");
  const auto pred7 = predict::predict_ssr(cloud, site, {}, popts);
  res.fig7_coverage = coverage(records, pred7, 0, M, 0);
  {
    const Eigen::ArrayXd obs = observed_mean(records, M);
    write("fig7_prediction.csv", [&](std::ostream& os) {
      os << "sensor,position_m,mean_if,lower95,upper95,mean_lower95,mean_upper95,observed_mean,observed_inside\n";
      for (int m = 0; m < M; ++m) {
        int in = 0;
        for (const auto& r : records) in += (r.impact_factor[m] >= pred7.lower95[m] && r.impact_factor[m] <= pred7.upper95[m]);
        os << (m + 1) << ',' << pred7.position_m[static_cast<std::size_t>(m)] << ',' << pred7.mean_if[m] << ','
           << pred7.lower95[m] << ',' << pred7.upper95[m] << ',' << pred7.mean_lower95[m] << ',' << pred7.mean_upper95[m]
           << ',' << obs[m] << ',' << static_cast<double>(in) / records.size() << '\n';
      }
    });
  }

  // Fig. 8: fit on sensors 1-10 only, predict sensors 11-16.
  {
    const int fitted = std::min(10, M - 1);
    site::SiteOptions so10;
    so10.sensors.count = fitted;
    const site::Site site10(site::load_road("AS1"), so10);
    std::vector<records::WimRecord> records10 = records;
    for (auto& r : records10) r.impact_factor = Eigen::VectorXd(r.impact_factor.head(fitted));
    const auto cloud10 = stream_fit(site10, records10, o, "fit on sensors 1-" + std::to_string(fitted) + " (Fig. 8)", {});
    const auto pred8 = predict::predict_ssr(cloud10, site, {}, popts);
    res.fig8_coverage = coverage(records, pred8, fitted, M, fitted);
    const Eigen::ArrayXd obs = observed_mean(records, M);
    Eigen::Index pk = 0, ok = 0;
    pred8.mean_if.segment(fitted, M - fitted).maxCoeff(&pk);
    obs.segment(fitted, M - fitted).maxCoeff(&ok);
    res.fig8_predicted_peak = static_cast<int>(pk) + fitted + 1;
    res.fig8_observed_peak = static_cast<int>(ok) + fitted + 1;
    const auto top2 = [&](const Eigen::ArrayXd& v) {
      std::vector<int> idx;
      for (int m = fitted; m < M; ++m) idx.push_back(m);
      std::sort(idx.begin(), idx.end(), [&](int a, int b) { return v[a] > v[b]; });
      std::array<int, 2> t{idx[0] + 1, idx.size() > 1 ? idx[1] + 1 : idx[0] + 1};
      std::sort(t.begin(), t.end());
      return t;
    };
    res.fig8_predicted_top2 = top2(pred8.mean_if);
    res.fig8_observed_top2 = top2(obs);
    for (int m = fitted; m < M; ++m) res.fig8_max_mean_diff = std::max(res.fig8_max_mean_diff, std::abs(pred8.mean_if[m] - obs[m]));
    write("fig8_prediction.csv", [&](std::ostream& os) {
      os << "sensor,position_m,used_in_fit,mean_if,lower95,upper95,mean_lower95,mean_upper95,observed_mean,observed_inside\n";
      for (int m = 0; m < M; ++m) {
        int in = 0;
        for (const auto& r : records) in += (r.impact_factor[m] >= pred8.lower95[m] && r.impact_factor[m] <= pred8.upper95[m]);
        os << (m + 1) << ',' << pred8.position_m[static_cast<std::size_t>(m)] << ',' << (m < fitted ? 1 : 0) << ','
           << pred8.mean_if[m] << ',' << pred8.lower95[m] << ',' << pred8.upper95[m] << ',' << pred8.mean_lower95[m]
           << ',' << pred8.mean_upper95[m] << ',' << obs[m] << ',' << static_cast<double>(in) / records.size() << '\n';
      }
    });
  }

  // Fig. 9: a new fleet (another seed) on AS2 and AS3 against the prediction from the AS1 fit.
  {
    const std::uint64_t seed9 = o.seed + 0x9E3779B97F4A7C15ULL;
    for (const std::string road : {"AS2", "AS3"}) {
      say("new " + std::to_string(o.trucks) + "-truck fleet on " + road + " vs the prediction from the AS1 fit (Fig. 9)");
      const site::Site other(site::load_road(road), site::SiteOptions{});
      const auto fleet9 = fleet::draw_fleet(dist, o.trucks, other.lateral_min_m(), other.lateral_max_m(), seed9);
      const auto log9 = fleet::simulate_log(other, fleet9, o.noise_sd, seed9);
      const auto pred9 = predict::predict_ssr(cloud, other, {}, popts);
      // The 100 new trucks' mean carries their own sampling error (about 0.01 IF on AS3, where
      // the truck-to-truck spread is widest), so the prediction is also compared with the
      // Table 1 fleet's population mean: 20000 trucks from the true distribution, no noise.
      const auto population9 = fleet::simulate_log(
          other, fleet::draw_fleet(dist, kPopulationTrucks, other.lateral_min_m(), other.lateral_max_m(), seed9 + 1), 0.0,
          seed9 + 1);
      SiteComparison cmp;
      cmp.road = road;
      cmp.sensors = M;
      cmp.coverage = coverage(log9.records, pred9, 0, M, 0);
      std::string name = "fig9_" + road;
      std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
      write(name + ".csv", [&](std::ostream& os) {
        os << "sensor,position_m,predicted_mean,predicted_lower95,predicted_upper95,true_mean,true_lower95,true_upper95,"
              "abs_mean_diff,population_mean,predicted_mean_lower95,predicted_mean_upper95\n";
        for (int m = 0; m < M; ++m) {
          const double true_mean = log9.model_if.row(m).mean();
          std::vector<double> y;
          for (const auto& r : log9.records) y.push_back(r.impact_factor[m]);
          const double tl = quantile_type7(y, 0.025), tu = quantile_type7(y, 0.975);
          const double d = std::abs(pred9.mean_if[m] - true_mean);
          if (d > cmp.max_abs_mean_diff) cmp.max_abs_mean_diff = d, cmp.max_mean_sensor = m + 1;
          const double population_mean = population9.model_if.row(m).mean();
          cmp.max_abs_population_diff = std::max(cmp.max_abs_population_diff, std::abs(pred9.mean_if[m] - population_mean));
          cmp.max_abs_oracle_diff = std::max(cmp.max_abs_oracle_diff, std::abs(population_mean - true_mean));
          cmp.band_covers_population += population_mean >= pred9.mean_lower95[m] && population_mean <= pred9.mean_upper95[m];
          cmp.max_band_half_width = std::max(cmp.max_band_half_width, 0.5 * (pred9.mean_upper95[m] - pred9.mean_lower95[m]));
          cmp.max_abs_limit_diff =
              std::max({cmp.max_abs_limit_diff, std::abs(pred9.lower95[m] - tl), std::abs(pred9.upper95[m] - tu)});
          os << (m + 1) << ',' << pred9.position_m[static_cast<std::size_t>(m)] << ',' << pred9.mean_if[m] << ','
             << pred9.lower95[m] << ',' << pred9.upper95[m] << ',' << true_mean << ',' << tl << ',' << tu << ',' << d
             << ',' << population_mean << ',' << pred9.mean_lower95[m] << ',' << pred9.mean_upper95[m] << '\n';
        }
      });
      res.fig9.push_back(cmp);
    }
  }

  // Plots.
  const auto scripts = plot_scripts();
  for (const auto& s : scripts) write(s.name + ".gp", [&](std::ostream& os) { os << s.script; });
  if (o.plots) {
    if (io::gnuplot_available()) {
      say("plotting with gnuplot (PNG and SVG)");
      const auto failed = io::run_gnuplot(o.out_dir, scripts);
      for (const auto& f : failed) say("warning: gnuplot failed on " + f + ".gp (see " + f + ".gnuplot.log)");
      res.plotted = failed.size() < scripts.size();
      for (const auto& s : scripts) {
        if (std::find(failed.begin(), failed.end(), s.name) == failed.end()) {
          res.files.push_back(s.name + ".png");
          res.files.push_back(s.name + ".svg");
        }
      }
    } else if (o.progress) {
      *o.progress << "reproduce: gnuplot is not on PATH: no PNG/SVG written; the scripts are in " << o.out_dir
                  << " (install gnuplot, e.g. apt-get install gnuplot-nox, then run `gnuplot fig7.gp` there)\n";
    }
  }

  res.total_wall_s = seconds_since(t0);

  // summary.md: measured beside the paper.
  write("summary.md", [&](std::ostream& os) { write_summary_markdown(os, o, res, history.size()); });
  say("done in " + fixed(seconds_since(t0), 1) + " s: Fig. 7 coverage " + pct(res.fig7_coverage) + ", Fig. 8 coverage " +
      pct(res.fig8_coverage) + ", " + std::to_string(res.hyper_covered) + "/7 truths inside their 95 % intervals -> " +
      o.out_dir + "/summary.md");
  return res;
}

}  // namespace ssrfleet::reproduce
