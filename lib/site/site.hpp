// A WIM site: a road surface (after tyre envelopment), the sensor array, and the vehicle
// constants the fleet model treats as known (unsprung mass m1, suspension damping c_b, tyre
// damping c_t). It turns trucks (speed, sprung mass, k, k_t, lateral position z) into impact
// factors at the sensors through the quarter-car integrator. It knows nothing about inference.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "road/missing_cells.hpp"
#include "road/surface.hpp"
#include "site/sensor_array.hpp"
#include "vehicle/pass_integrator.hpp"
#include "vehicle/quarter_car.hpp"

namespace ssrfleet::site {

struct SiteOptions {
  double envelopment_m = 0.3;            // tyre envelopment base length; 0 = off
  SensorArray sensors;
  double unsprung_mass_kg = 420.0;       // m1
  double suspension_damping_nspm = 20e3; // c_b
  double tyre_damping_nspm = 0.0;        // c_t

  void validate() const;  // UsageError naming the option
};

// Trucks as arrays (structure of arrays): one entry per truck.
struct TruckBatch {
  Eigen::ArrayXd speed_mps;
  Eigen::ArrayXd sprung_mass_kg;
  Eigen::ArrayXd stiffness_npm;
  Eigen::ArrayXd tyre_stiffness_npm;
  Eigen::ArrayXd lateral_m;

  Eigen::Index size() const { return speed_mps.size(); }
  void resize(Eigen::Index n);
};

class Site {
 public:
  // Applies the envelopment filter to the raw surface and checks that every sensor lies on the
  // road (UsageError: "sensor 16 at 120 m is beyond the road's end at 100 m") and that the
  // trucks' stretch, x = 0 to the last sensor across the whole width (a truck may sit anywhere
  // across the surface), reads no missing cell (DataError naming the road and the first missing
  // cell). Missing cells beyond the last sensor are allowed.
  Site(road::Surface raw_surface, SiteOptions options);

  const road::Surface& surface() const { return surface_; }
  const SiteOptions& options() const { return options_; }
  const std::vector<double>& sensor_positions_m() const { return integrator_.positions_m(); }
  int sensors() const { return static_cast<int>(integrator_.positions_m().size()); }
  const vehicle::PassIntegrator& integrator() const { return integrator_; }

  double lateral_min_m() const { return surface_.y0_m; }
  double lateral_max_m() const { return surface_.y_max_m(); }
  // The wheel path at lateral position z (linear between the two nearest lines). z outside the
  // surface throws std::out_of_range: an error, never a clamp.
  vehicle::WheelPath wheel_path(double lateral_m) const;

  vehicle::QuarterCar car(double sprung_mass_kg, double stiffness_npm, double tyre_stiffness_npm) const;

  // Impact factors at the sensors, sensors x trucks, through the batched integrator; min_if (if
  // given) receives each pass's minimum IF (< 0 is wheel lift-off).
  void impact_factors(const TruckBatch& trucks, Eigen::Ref<Eigen::ArrayXXd> if_out,
                      Eigen::ArrayXd* min_if = nullptr) const;

  // Lines first_line .. first_line + count - 1 of the surface, transposed for run_on_lines
  // (std::out_of_range if they are not all on the surface).
  vehicle::LineBundle line_bundle(Eigen::Index first_line, Eigen::Index count) const;

  // Cars at one speed, car c with sprung mass, k and k_t from entry c of the arrays, each over
  // every line of `lines` (exactly on the line): if_out is sensors x (cars x lines), car-major.
  // The same impact factors as impact_factors() with z on those lines, faster when many cars
  // share them (vehicle::PassIntegrator::run_on_lines).
  void impact_factors_on_lines(double speed_mps, const Eigen::ArrayXd& sprung_mass_kg, const Eigen::ArrayXd& stiffness_npm,
                               const Eigen::ArrayXd& tyre_stiffness_npm, const vehicle::LineBundle& lines,
                               Eigen::Ref<Eigen::ArrayXXd> if_out) const;

  // The same with an integrator built for other output positions (e.g. predict anywhere); a
  // position whose pass would read a missing cell is a DataError, as in the constructor.
  void impact_factors_at(const vehicle::PassIntegrator& integrator, const TruckBatch& trucks,
                         Eigen::Ref<Eigen::ArrayXXd> if_out, Eigen::ArrayXd* min_if = nullptr) const;

  // A digest of everything that changes the site's predictions (surface heights and geometry,
  // sensor positions, constants), so a posterior fitted on one site is not used on another by
  // mistake. Hex, 16 digits. Computed once, at construction: a stream asks for it at every truck
  // (its posterior file and checkpoint name the site), and hashing a whole surface each time was a
  // tenth of a stream's time.
  const std::string& fingerprint() const { return fingerprint_; }

 private:
  // The quarter cars of trucks with these masses and stiffnesses and the site's constants (one
  // copy for impact_factors_at and impact_factors_on_lines).
  vehicle::QuarterCarBatch cars(const Eigen::ArrayXd& sprung_mass_kg, const Eigen::ArrayXd& stiffness_npm,
                                const Eigen::ArrayXd& tyre_stiffness_npm) const;

  // DataError unless a pass to x_m reads only measured road.
  void check_measured_up_to(double x_m) const;

  road::Surface surface_;
  SiteOptions options_;
  vehicle::PassIntegrator integrator_;
  road::MissingCells raw_missing_;  // in the raw surface, for messages
  double measured_to_m_;            // a pass may run this far and read no missing cell
  std::string fingerprint_;

  std::string compute_fingerprint() const;
};

}  // namespace ssrfleet::site
