#include "damage/damage_profile.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include <boost/random/mersenne_twister.hpp>

#include "fleet/predictive_trucks.hpp"
#include "fleet/vehicle_classes.hpp"
#include "model/physical_effects.hpp"
#include "util/errors.hpp"
#include "util/stop_token.hpp"
#include "util/quantile.hpp"
#include "vehicle/quarter_car.hpp"

namespace ssrfleet::damage {

void DamageOptions::validate() const {
  if (theta_draws < 2) throw UsageError("--draws is " + std::to_string(theta_draws) + ", but must be >= 2");
  if (trucks_per_draw < 1) throw UsageError("--trucks-per-draw is " + std::to_string(trucks_per_draw) + ", but must be >= 1");
  if (!(hot_spot_threshold > 0.0) || !std::isfinite(hot_spot_threshold)) {
    throw UsageError("--threshold is " + std::to_string(hot_spot_threshold) + ", but must be a finite number > 0");
  }
  const auto all = powers();
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (!(all[i] > 0.0) || !std::isfinite(all[i]) || all[i] > 20.0) {
      throw UsageError("--power " + std::to_string(all[i]) + ": a power must be in (0, 20]");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (all[j] == all[i]) throw UsageError("--power " + std::to_string(all[i]) + " is asked twice (1 and 4 are always reported)");
    }
  }
}

std::vector<double> DamageOptions::powers() const {
  std::vector<double> p{1.0, 4.0};
  p.insert(p.end(), extra_powers.begin(), extra_powers.end());
  return p;
}

namespace {
// x^n, with the integer powers (the usual ones) exact and fast.
double power_of(double x, double n) {
  if (n == 1.0) return x;
  if (n == 4.0) {
    const double x2 = x * x;
    return x2 * x2;
  }
  return std::pow(x, n);
}

struct Band {
  double mean, q025, q975;
};
Band band(std::vector<double>& per_draw) {
  double sum = 0.0;
  for (double v : per_draw) sum += v;
  const double mean = sum / static_cast<double>(per_draw.size());
  const double lo = quantile_type7(per_draw, 0.025), hi = quantile_type7(per_draw, 0.975);
  return {mean, lo, hi};
}
}  // namespace

records::DamageProfile summarise_damage(const std::vector<double>& position_m, const Eigen::ArrayXXd& wheel_if,
                                        const Eigen::ArrayXd& static_load_n, int R, int T,
                                        const DamageOptions& options, const Eigen::ArrayXd& truck_weight) {
  options.validate();
  const auto n_pos = static_cast<Eigen::Index>(position_m.size());
  const Eigen::Index columns = static_cast<Eigen::Index>(R) * T;
  if (R < 2 || T < 1 || wheel_if.rows() != n_pos || wheel_if.cols() != columns || static_load_n.size() != columns) {
    throw std::invalid_argument("summarise_damage: want positions x (R * T) impact factors and R * T static loads");
  }
  const bool weighted = truck_weight.size() > 0;
  if (weighted && (truck_weight.size() != T || (truck_weight < 0.0).any() || std::abs(truck_weight.sum() - 1.0) > 1e-9)) {
    throw std::invalid_argument("summarise_damage: want T truck weights >= 0 summing to 1");
  }
  // The mean over θ draw r's trucks of f(column): plain (sum / T) or by the trucks' weights.
  const auto draw_mean = [&](int r, const auto& f) {
    double sum = 0.0;
    if (!weighted) {
      for (int t = 0; t < T; ++t) sum += f(static_cast<Eigen::Index>(r) * T + t);
      return sum / T;
    }
    for (int t = 0; t < T; ++t) sum += truck_weight[t] * f(static_cast<Eigen::Index>(r) * T + t);
    return sum;
  };
  const std::vector<double> powers = options.powers();
  records::DamageProfile out;
  out.position_m = position_m;
  out.hot_spot_threshold = options.hot_spot_threshold;
  out.simulated_passes = static_cast<long>(columns);
  for (Eigen::Index b = 0; b < columns; ++b) {
    if ((!weighted || truck_weight[b % T] > 0.0) && (wheel_if.col(b) < 0.0).any()) ++out.lift_off_passes;
  }
  if (weighted) out.simulated_passes = static_cast<long>(R) * (truck_weight > 0.0).count();
  out.dlc.resize(position_m.size());
  out.hot_spot.resize(position_m.size());
  out.esal_per_million.resize(position_m.size());
  out.esal_per_million_q025.resize(position_m.size());
  out.esal_per_million_q975.resize(position_m.size());
  for (double n : powers) {
    records::PowerAmplification a;
    a.power = n;
    a.mean.resize(position_m.size());
    a.q025.resize(position_m.size());
    a.q975.resize(position_m.size());
    out.powers.push_back(std::move(a));
  }

  // ESAL of one wheel load P: (axle load / standard axle)^4 with the axle carrying two wheels.
  const auto esal = [](double wheel_load_n) { return power_of(kWheelsPerAxle * wheel_load_n / kStandardAxleN, 4.0); };
  double static_esal = 0.0;
  if (!weighted) {
    for (Eigen::Index b = 0; b < columns; ++b) static_esal += esal(static_load_n[b]);
  } else {
    for (int r = 0; r < R; ++r) static_esal += T * draw_mean(r, [&](Eigen::Index b) { return esal(static_load_n[b]); });
  }
  // The static damage averages over every θ draw's traffic (the bootstrap weighs the observed
  // trucks differently per draw, equally on average).
  out.static_esal_per_million = 1e6 * static_esal / static_cast<double>(columns);

  std::vector<double> per_draw(static_cast<std::size_t>(R)), dlc_draw(static_cast<std::size_t>(R)),
      esal_draw(static_cast<std::size_t>(R));
  for (Eigen::Index m = 0; m < n_pos; ++m) {
    const auto i = static_cast<std::size_t>(m);
    for (std::size_t k = 0; k < powers.size(); ++k) {
      for (int r = 0; r < R; ++r) {
        per_draw[static_cast<std::size_t>(r)] =
            draw_mean(r, [&](Eigen::Index b) { return power_of(std::max(0.0, wheel_if(m, b)), powers[k]); });
      }
      auto& a = out.powers[k];
      const Band b = band(per_draw);
      a.mean[i] = b.mean;
      a.q025[i] = b.q025;
      a.q975[i] = b.q975;
      // Hot spot: the fleet's fourth-power amplification could exceed the threshold, i.e. its
      // 95th percentile over the posterior does (per_draw is sorted by band()).
      if (powers[k] == 4.0) out.hot_spot[i] = quantile_type7(per_draw, 0.95) > options.hot_spot_threshold;
    }
    for (int r = 0; r < R; ++r) {
      // Plug-in moments over the T trucks (divide by T): the fleet's sd, consistent with a_n,
      // which are plug-in means too.
      if (!weighted) {
        double s1 = 0.0, s2 = 0.0, e = 0.0;
        for (int t = 0; t < T; ++t) {
          const Eigen::Index b = static_cast<Eigen::Index>(r) * T + t;
          const double x = wheel_if(m, b);
          s1 += x;
          s2 += x * x;
          e += esal(std::max(0.0, x) * static_load_n[b]);
        }
        const double mean = s1 / T;
        dlc_draw[static_cast<std::size_t>(r)] = std::sqrt(std::max(0.0, s2 / T - mean * mean));
        esal_draw[static_cast<std::size_t>(r)] = 1e6 * e / T;
      } else {
        // The mixture's moments: E[IF], E[IF^2] and the ESAL weighted over every class's trucks.
        const double mean = draw_mean(r, [&](Eigen::Index b) { return wheel_if(m, b); });
        const double second = draw_mean(r, [&](Eigen::Index b) { return wheel_if(m, b) * wheel_if(m, b); });
        dlc_draw[static_cast<std::size_t>(r)] = std::sqrt(std::max(0.0, second - mean * mean));
        esal_draw[static_cast<std::size_t>(r)] =
            1e6 * draw_mean(r, [&](Eigen::Index b) { return esal(std::max(0.0, wheel_if(m, b)) * static_load_n[b]); });
      }
    }
    double dlc_sum = 0.0;
    for (double v : dlc_draw) dlc_sum += v;
    out.dlc[i] = dlc_sum / R;
    const Band eb = band(esal_draw);
    out.esal_per_million[i] = eb.mean;
    out.esal_per_million_q025[i] = eb.q025;
    out.esal_per_million_q975[i] = eb.q975;
  }
  return out;
}

namespace {
// One class's predictive trucks at the positions: the wheel IFs and static loads (θ-draw-major).
struct Simulated {
  Eigen::ArrayXXd wheel_if;
  Eigen::ArrayXd static_load_n;
};

Simulated simulate(const fleet::PosteriorCloud& posterior, const site::Site& site,
                   const vehicle::PassIntegrator& integrator, std::size_t n_pos, const DamageOptions& options) {
  util::throw_if_stopped();
  boost::random::mt19937_64 engine(options.seed);
  fleet::PredictiveTraffic traffic;
  traffic.bootstrap = options.traffic_bootstrap;
  // A fitted model's effects as predict keeps them: what the road feels (model/physical_effects.hpp).
  const fleet::ModelSpec model = fleet::posterior_model(posterior, site);
  std::unique_ptr<fleet::PhysicalEffects> effects;
  if (model.extension) {
    effects = std::make_unique<fleet::PhysicalEffects>(*model.extension, posterior.site_fingerprint == site.fingerprint());
  }
  const fleet::PredictiveTrucks drawn =
      fleet::draw_predictive_trucks(posterior, site.lateral_min_m(), site.lateral_max_m(), options.theta_draws,
                                    options.trucks_per_draw, traffic, engine, effects.get());
  Simulated out;
  out.wheel_if.resize(static_cast<Eigen::Index>(n_pos), drawn.trucks.size());
  fleet::simulate_predictive_trucks(site, &integrator, posterior, drawn, effects.get(), out.wheel_if);
  out.static_load_n = (drawn.trucks.sprung_mass_kg + site.options().unsprung_mass_kg) * vehicle::gravity_mps2;
  return out;
}
}  // namespace

records::DamageProfile predict_damage(const fleet::PosteriorCloud& posterior, const site::Site& site,
                                      std::vector<double> positions_m, const DamageOptions& options) {
  options.validate();
  if (positions_m.empty()) positions_m = site.sensor_positions_m();
  const vehicle::PassIntegrator integrator(site.surface().dx_m, site.surface().samples(), positions_m);
  const Simulated sim = simulate(posterior, site, integrator, positions_m.size(), options);
  return summarise_damage(positions_m, sim.wheel_if, sim.static_load_n, options.theta_draws, options.trucks_per_draw,
                          options);
}

records::DamageProfile predict_damage_mixture(const fleet::ClassPosteriors& classes, const std::vector<double>& shares,
                                              const site::Site& site, std::vector<double> positions_m,
                                              const DamageOptions& options) {
  options.validate();
  if (classes.empty() || shares.size() != classes.size()) {
    throw std::invalid_argument("predict_damage_mixture: want one share per class");
  }
  std::vector<std::size_t> used;
  for (std::size_t c = 0; c < classes.size(); ++c) {
    if (shares[c] > 0.0) used.push_back(c);
  }
  if (used.empty()) throw UsageError("damage: every class has share 0");
  const auto class_options = [&](std::size_t c) {
    DamageOptions o = options;
    o.seed = fleet::class_seed(options.seed, classes[c].label);
    return o;
  };
  if (used.size() == 1) return predict_damage(classes[used[0]].cloud, site, std::move(positions_m), class_options(used[0]));

  if (positions_m.empty()) positions_m = site.sensor_positions_m();
  const vehicle::PassIntegrator integrator(site.surface().dx_m, site.surface().samples(), positions_m);
  const int R = options.theta_draws, T = options.trucks_per_draw;
  const auto C = static_cast<int>(used.size());
  double total_share = 0.0;
  for (const std::size_t c : used) total_share += shares[c];
  // θ draw r of the mixture is draw r of every class (independent posteriors): its C T trucks,
  // class by class, become the columns r C T + k T + t, truck t of class k weighing w_k / T.
  Eigen::ArrayXXd wheel_if(static_cast<Eigen::Index>(positions_m.size()), static_cast<Eigen::Index>(R) * C * T);
  Eigen::ArrayXd static_load_n(wheel_if.cols()), truck_weight(static_cast<Eigen::Index>(C) * T);
  for (int k = 0; k < C; ++k) {
    const std::size_t c = used[static_cast<std::size_t>(k)];
    const Simulated sim = simulate(classes[c].cloud, site, integrator, positions_m.size(), class_options(c));
    truck_weight.segment(static_cast<Eigen::Index>(k) * T, T).setConstant(shares[c] / total_share / T);
    for (int r = 0; r < R; ++r) {
      const Eigen::Index from = static_cast<Eigen::Index>(r) * T, to = (static_cast<Eigen::Index>(r) * C + k) * T;
      wheel_if.middleCols(to, T) = sim.wheel_if.middleCols(from, T);
      static_load_n.segment(to, T) = sim.static_load_n.segment(from, T);
    }
  }
  truck_weight /= truck_weight.sum();
  return summarise_damage(positions_m, wheel_if, static_load_n, R, C * T, options, truck_weight);
}

}  // namespace ssrfleet::damage
