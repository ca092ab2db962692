// Cost of one truck-pass over the MS-WIM site (98.5 m at 0.05 m: 1971 samples, 1970 steps,
// 16 sensors at 76.0-98.5 m), for:
//   single  - PassIntegrator::run, one truck at a time, including its discretisation;
//   batched - PassIntegrator::run_batch on a fleet, including every truck's discretisation;
//   table   - a truck table's passes (one truck at 64 (k, k_t) nodes, each on the same 8 lateral
//             lines) through run_batch and through run_on_lines (a LineBundle of the 8 lines);
//   floor   - the bare recurrence z <- Phi z + gamma r_j over the same 1970 steps with fixed
//             per-truck matrices, laid out and vectorised the same way (structure of arrays
//             over trucks, the same block size), no discretisation, no outputs, one shared
//             profile: what any exact-discretisation integrator must at least cost.
// Repetitions of the three are interleaved and medians reported.
//
//   integrator_benchmark [--trucks N] [--reps R] [--json FILE]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "vehicle/discretisation.hpp"
#include "vehicle/line_bundle.hpp"
#include "vehicle/pass_integrator.hpp"
#include "vehicle/quarter_car.hpp"

using namespace ssrfleet::vehicle;
using Clock = std::chrono::steady_clock;

namespace {

constexpr double kDx = 0.05;
constexpr Eigen::Index kSamples = 1971;
constexpr int kLines = 8;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Floor kernel state: one block of BS trucks, as in run_batch.
template <int BS>
struct alignas(64) FloorBlock {
  double phi[16][BS];
  double gamma[4][BS];
  double z[4][BS];
};

template <int BS>
double floor_block(FloorBlock<BS>& s, const double* r, Eigen::Index steps) {
  for (Eigen::Index j = 0; j < steps; ++j) {
    const double rj = r[j];
#pragma GCC ivdep
    for (int t = 0; t < BS; ++t) {
      const double z0 = s.z[0][t], z1 = s.z[1][t], z2 = s.z[2][t], z3 = s.z[3][t];
      s.z[0][t] = ((s.phi[0][t] * z0 + s.phi[1][t] * z1) + (s.phi[2][t] * z2 + s.phi[3][t] * z3)) +
                  s.gamma[0][t] * rj;
      s.z[1][t] = ((s.phi[4][t] * z0 + s.phi[5][t] * z1) + (s.phi[6][t] * z2 + s.phi[7][t] * z3)) +
                  s.gamma[1][t] * rj;
      s.z[2][t] = ((s.phi[8][t] * z0 + s.phi[9][t] * z1) + (s.phi[10][t] * z2 + s.phi[11][t] * z3)) +
                  s.gamma[2][t] * rj;
      s.z[3][t] = ((s.phi[12][t] * z0 + s.phi[13][t] * z1) + (s.phi[14][t] * z2 + s.phi[15][t] * z3)) +
                  s.gamma[3][t] * rj;
    }
  }
  double sum = 0.0;
  for (int i = 0; i < 4; ++i)
    for (int t = 0; t < BS; ++t) sum += s.z[i][t];
  return sum;
}

}  // namespace

int main(int argc, char** argv) {
  int trucks = 1024, reps = 21, single_trucks = 128;
  std::string json_path;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--trucks" && i + 1 < argc)
      trucks = std::stoi(argv[++i]);
    else if (a == "--reps" && i + 1 < argc)
      reps = std::stoi(argv[++i]);
    else if (a == "--json" && i + 1 < argc)
      json_path = argv[++i];
    else {
      std::cerr << "usage: integrator_benchmark [--trucks N] [--reps R] [--json FILE]\n";
      return 64;
    }
  }
  single_trucks = std::min(single_trucks, trucks);

  // Road: kLines rough lines (a sum of random-phase sinusoids, AS1-like level).
  std::mt19937_64 engine(1);
  const auto u01 = [&] { return static_cast<double>(engine() >> 11) * 0x1.0p-53; };
  std::vector<std::vector<double>> lines(kLines,
                                         std::vector<double>(static_cast<std::size_t>(kSamples), 0.0));
  for (auto& line : lines)
    for (int i = 1; i <= 200; ++i) {
      const double n = 0.05 * i, amp = std::sqrt(2.0 * 20e-6 * std::pow(n / 0.1, -2.0) * 0.05);
      const double phase = 2.0 * std::numbers::pi * u01();
      for (std::size_t j = 0; j < line.size(); ++j)
        line[j] += amp * std::sin(2.0 * std::numbers::pi * n * kDx * static_cast<double>(j) + phase);
    }

  // Fleet: Table 1 draws (docs/model.md).
  std::normal_distribution<double> normal;
  QuarterCarBatch cars;
  cars.assign(trucks, QuarterCar{});
  Eigen::ArrayXd speeds(trucks);
  std::vector<WheelPath> paths;
  for (int i = 0; i < trucks; ++i) {
    QuarterCar car;
    car.sprung_mass_kg = 4450.0 + 445.0 * normal(engine);
    car.suspension_stiffness_npm = 500e3 + 50e3 * normal(engine);
    car.tyre_stiffness_npm = 1950e3 + 195e3 * normal(engine);
    cars.set_car(i, car);
    speeds[i] = std::clamp(23.43 + 2.08 * normal(engine), 15.0, 32.0);
    const int a = static_cast<int>(u01() * (kLines - 1));
    paths.push_back(WheelPath{lines[static_cast<std::size_t>(a)].data(),
                              lines[static_cast<std::size_t>(a + 1)].data(), u01()});
  }
  std::vector<double> sensors;
  for (int i = 0; i < 16; ++i) sensors.push_back(76.0 + 1.5 * i);
  const PassIntegrator integrator(kDx, kSamples, sensors);
  const Eigen::Index steps = kSamples - 1;

  // Floor kernel inputs: each truck's own Phi and gamma (fixed for the pass, prepared untimed).
  constexpr int BS = batch_block_trucks;
  const int blocks = (trucks + BS - 1) / BS;
  std::vector<FloorBlock<BS>> floor_blocks(static_cast<std::size_t>(blocks));
  for (int b = 0; b < blocks; ++b)
    for (int t = 0; t < BS; ++t) {
      const int i = std::min(b * BS + t, trucks - 1);
      const StateSpace ss = state_space(cars.car(i));
      const Discretisation<2> d = discretise<2>(ss.A, ss.B, kDx / speeds[i]);
      const Eigen::Vector4d g = d.Gamma0.col(0);
      for (int r = 0; r < 16; ++r) floor_blocks[static_cast<std::size_t>(b)].phi[r][t] = d.Phi(r / 4, r % 4);
      for (int r = 0; r < 4; ++r) floor_blocks[static_cast<std::size_t>(b)].gamma[r][t] = g[r];
    }

  // A truck table's passes: one truck (the first) at 64 nodes around its (k, k_t), each on every line.
  constexpr int kNodes = 64;
  QuarterCarBatch nodes, node_lanes;
  nodes.assign(kNodes, cars.car(0));
  node_lanes.assign(kNodes * kLines, cars.car(0));
  std::vector<WheelPath> node_paths;
  std::vector<const double*> line_pointers;
  for (const auto& line : lines) line_pointers.push_back(line.data());
  for (int g = 0; g < kNodes; ++g) {
    nodes.suspension_stiffness_npm[g] *= 0.8 + 0.4 * (g % 8) / 7.0;
    nodes.tyre_stiffness_npm[g] *= 0.8 + 0.4 * (g / 8) / 7.0;
    for (int l = 0; l < kLines; ++l) {
      node_lanes.set_car(g * kLines + l, nodes.car(g));
      node_paths.push_back(WheelPath{line_pointers[static_cast<std::size_t>(l)], line_pointers[static_cast<std::size_t>(l)], 0.0});
    }
  }
  const LineBundle bundle(line_pointers, kSamples);
  const Eigen::ArrayXd node_speeds = Eigen::ArrayXd::Constant(kNodes * kLines, speeds[0]);
  Eigen::ArrayXXd table_out(16, kNodes * kLines);
  std::vector<double> t_table_batch, t_table_lines;

  Eigen::ArrayXXd batch_out(16, trucks);
  Eigen::ArrayXd batch_min;
  Eigen::VectorXd single_out(16);
  std::vector<double> t_single, t_batch, t_floor, t_disc;
  double sink = 0.0;
  for (int rep = 0; rep < reps; ++rep) {
    auto t0 = Clock::now();
    for (int i = 0; i < single_trucks; ++i)
      sink += integrator.run(cars.car(i), speeds[i], paths[static_cast<std::size_t>(i)], single_out).min_if;
    t_single.push_back(seconds_since(t0) / single_trucks);

    t0 = Clock::now();
    integrator.run_batch(cars, speeds, paths, batch_out, &batch_min);
    t_batch.push_back(seconds_since(t0) / trucks);
    sink += batch_min[0];

    t0 = Clock::now();
    integrator.run_batch(node_lanes, node_speeds, node_paths, table_out);
    t_table_batch.push_back(seconds_since(t0) / (kNodes * kLines));
    sink += table_out(0, 0);

    t0 = Clock::now();
    integrator.run_on_lines(nodes, speeds[0], bundle, table_out);
    t_table_lines.push_back(seconds_since(t0) / (kNodes * kLines));
    sink += table_out(0, 0);

    t0 = Clock::now();
    for (auto& block : floor_blocks) {
      for (int i = 0; i < 4; ++i)
        for (int t = 0; t < BS; ++t) block.z[i][t] = 0.0;
      sink += floor_block(block, lines[0].data(), steps);
    }
    t_floor.push_back(seconds_since(t0) / (blocks * BS));

    t0 = Clock::now();
    for (int i = 0; i < single_trucks; ++i) {
      const StateSpace ss = state_space(cars.car(i));
      sink += discretise<2>(ss.A, ss.B, kDx / speeds[i]).Phi(0, 0);
    }
    t_disc.push_back(seconds_since(t0) / single_trucks);
  }
  const double us_single = 1e6 * median(t_single), us_batch = 1e6 * median(t_batch),
               us_floor = 1e6 * median(t_floor), us_disc = 1e6 * median(t_disc),
               us_table_batch = 1e6 * median(t_table_batch), us_table_lines = 1e6 * median(t_table_lines);

#if defined(__AVX512F__)
  const char* isa = "avx512";
#elif defined(__AVX2__)
  const char* isa = "avx2";
#elif defined(__AVX__)
  const char* isa = "avx";
#else
  const char* isa = "sse2";
#endif
  std::printf(
      "integrator benchmark: %lld samples (%lld steps) at %.2f m, 16 sensors, %d trucks (single: %d), "
      "%d interleaved reps, medians; block %d trucks, ISA %s\n",
      static_cast<long long>(kSamples), static_cast<long long>(steps), kDx, trucks, single_trucks, reps, BS,
      isa);
  std::printf("%-34s %14s %16s\n", "variant", "us/truck-pass", "passes/s/core");
  const auto row = [](const char* name, double us) {
    std::printf("%-34s %14.3f %16.0f\n", name, us, 1e6 / us);
  };
  row("single (run, incl. discretisation)", us_single);
  row("batched (run_batch, incl. discr.)", us_batch);
  row("table: run_batch on the lines", us_table_batch);
  row("table: run_on_lines (LineBundle)", us_table_lines);
  row("floor (bare recurrence, SoA)", us_floor);
  row("discretisation alone (per truck)", us_disc);
  std::printf("ratio batched / floor:  %.2f   (target <= 2.0)\n", us_batch / us_floor);
  std::printf("ratio single / batched: %.2f   (target >= 5.0)\n", us_single / us_batch);
  std::printf("ratio table run_batch / run_on_lines: %.2f\n", us_table_batch / us_table_lines);
  std::fprintf(stderr, "(checksum %g)\n", sink);

  if (!json_path.empty()) {
    nlohmann::json j;
    j["benchmark"] = "integrator";
    j["samples"] = kSamples;
    j["steps"] = steps;
    j["trucks"] = trucks;
    j["reps"] = reps;
    j["block_trucks"] = BS;
    j["isa"] = isa;
    j["us_per_pass"] = {
        {"single", us_single}, {"batched", us_batch}, {"floor", us_floor}, {"discretisation", us_disc},
        {"table_run_batch", us_table_batch}, {"table_run_on_lines", us_table_lines}};
    j["ratio_batched_over_floor"] = us_batch / us_floor;
    j["ratio_single_over_batched"] = us_single / us_batch;
    j["ratio_table_batch_over_lines"] = us_table_batch / us_table_lines;
    std::ofstream out(json_path);
    out << j.dump(2) << "\n";
    if (!out) {
      std::cerr << "integrator_benchmark: cannot write " << json_path << "\n";
      return 74;
    }
  }
  return 0;
}
