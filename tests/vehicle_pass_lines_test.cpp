// PassIntegrator::run_on_lines (pass_lines.cpp) against run_batch on the same passes: every car
// over every line of a bundle, for line counts that take each block width (8, 16, 24, 32 lanes)
// and more than one block, with damped and undamped tyres and outputs between samples.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <vector>

#include "vehicle/line_bundle.hpp"
#include "vehicle/pass_integrator.hpp"
#include "vehicle/quarter_car.hpp"

using namespace ssrfleet::vehicle;

namespace {

// A rough random line: a random walk smoothed by a short moving average (heights of a few cm).
std::vector<double> random_line(std::size_t samples, std::mt19937_64& engine) {
  std::normal_distribution<double> step(0.0, 4e-4);
  std::vector<double> walk(samples), line(samples);
  double h = 0.0;
  for (auto& w : walk) w = (h += step(engine));
  for (std::size_t j = 0; j < samples; ++j) {
    double sum = 0.0;
    int count = 0;
    for (std::size_t i = j >= 2 ? j - 2 : 0; i <= std::min(samples - 1, j + 2); ++i, ++count) sum += walk[i];
    line[j] = sum / count;
  }
  return line;
}

}  // namespace

TEST_CASE("passes on a line bundle agree with batched passes on the same lines", "[vehicle][pass_integrator]") {
  const double dx = 0.05;
  const std::size_t samples = 2001;
  std::mt19937_64 engine(77);
  std::vector<std::vector<double>> surface;
  for (int l = 0; l < 45; ++l) surface.push_back(random_line(samples, engine));
  std::vector<double> positions;
  for (int i = 0; i < 16; ++i) positions.push_back(76.0 + 1.5 * i);
  positions.insert(positions.begin() + 3, 79.013);  // between samples: a partial step
  const PassIntegrator integrator(dx, static_cast<Eigen::Index>(samples), positions);
  const auto P = static_cast<Eigen::Index>(positions.size());
  std::uniform_real_distribution<double> u(0.0, 1.0);

  for (int lines : {1, 3, 6, 8, 11, 13, 18, 21, 26, 32, 45}) {
    for (double tyre_damping : {0.0, 1500.0}) {
      INFO("lines " << lines << ", tyre damping " << tyre_damping);
      const int first = 45 - lines;
      std::vector<const double*> pointers;
      for (int l = first; l < first + lines; ++l) pointers.push_back(surface[static_cast<std::size_t>(l)].data());
      const LineBundle bundle(pointers, static_cast<Eigen::Index>(samples));
      REQUIRE(bundle.lines() == lines);
      REQUIRE(bundle.lanes() % 4 == 0);
      REQUIRE(bundle.lanes() - lines < 4);
      const Eigen::Index cars_n = 3;
      QuarterCarBatch cars;
      cars.assign(cars_n, QuarterCar{});
      for (Eigen::Index c = 0; c < cars_n; ++c) {
        QuarterCar car;
        car.sprung_mass_kg = 3000.0 + 3000.0 * u(engine);
        car.suspension_stiffness_npm = 300e3 + 400e3 * u(engine);
        car.tyre_stiffness_npm = 1.5e6 + 1e6 * u(engine);
        car.tyre_damping_nspm = tyre_damping;
        cars.set_car(c, car);
      }
      const double speed = 15.0 + 15.0 * u(engine);
      Eigen::ArrayXXd on_lines(P, cars_n * lines);
      integrator.run_on_lines(cars, speed, bundle, on_lines);

      // The same passes through run_batch: car-major, line-minor, each path on its line.
      QuarterCarBatch each;
      each.assign(cars_n * lines, QuarterCar{});
      std::vector<WheelPath> paths;
      for (Eigen::Index c = 0; c < cars_n; ++c) {
        for (int l = 0; l < lines; ++l) {
          each.set_car(c * lines + l, cars.car(c));
          paths.push_back({pointers[static_cast<std::size_t>(l)], pointers[static_cast<std::size_t>(l)], 0.0});
        }
      }
      Eigen::ArrayXXd batched(P, cars_n * lines);
      integrator.run_batch(each, Eigen::ArrayXd::Constant(cars_n * lines, speed), paths, batched);
      const double worst = (on_lines - batched).abs().maxCoeff();
      CHECK(worst <= 1e-12);
      // The passes are not trivial: the dynamic part of the IF is of the order of 0.01 or more.
      CHECK((batched - 1.0).abs().maxCoeff() > 1e-3);
    }
  }
}

TEST_CASE("passes on a line bundle reject bad arguments naming the field", "[vehicle][pass_integrator]") {
  const std::vector<double> line(2001, 0.0);
  const PassIntegrator integrator(0.05, 2001, {76.0, 98.5});
  const LineBundle bundle({line.data(), line.data()}, 2001);
  QuarterCarBatch cars;
  cars.assign(2, QuarterCar{});
  Eigen::ArrayXXd out(2, 4);
  REQUIRE_THROWS_WITH(integrator.run_on_lines(cars, 0.0, bundle, out), Catch::Contains("speed_mps"));
  Eigen::ArrayXXd wrong(2, 3);
  REQUIRE_THROWS_WITH(integrator.run_on_lines(cars, 20.0, bundle, wrong), Catch::Contains("if_out is 2 x 3"));
  cars.tyre_stiffness_npm[1] = -1.0;
  REQUIRE_THROWS_WITH(integrator.run_on_lines(cars, 20.0, bundle, out),
                      Catch::Contains("car 1") && Catch::Contains("tyre_stiffness_npm"));
  const LineBundle short_lines({line.data()}, 1000);
  cars.tyre_stiffness_npm[1] = 1.9e6;
  REQUIRE_THROWS_WITH(integrator.run_on_lines(cars, 20.0, short_lines, out), Catch::Contains("1000 samples"));
  REQUIRE_THROWS_WITH(LineBundle({}, 2001), Catch::Contains("no lines"));
  REQUIRE_THROWS_WITH(LineBundle({line.data(), nullptr}, 2001), Catch::Contains("line 1 is null"));
}
