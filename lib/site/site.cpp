#include "site/site.hpp"

#include <cmath>
#include <cstring>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "road/envelopment.hpp"
#include "road/wheel_path.hpp"
#include "util/errors.hpp"

namespace ssrfleet::site {

namespace {
vehicle::PassIntegrator make_integrator(const road::Surface& surface, const SensorArray& sensors) {
  const std::vector<double> positions = sensors.positions_m();
  for (std::size_t m = 0; m < positions.size(); ++m) {
    if (positions[m] > surface.length_m() + 1e-9) {
      std::ostringstream os;
      os << "sensor " << (m + 1) << " at " << positions[m] << " m is beyond the road's end at "
         << surface.length_m() << " m (road '" << surface.name << "')";
      throw UsageError(os.str());
    }
  }
  return vehicle::PassIntegrator(surface.dx_m, surface.samples(), positions);
}

void check_nonneg(double v, const char* what) {
  if (!(std::isfinite(v) && v >= 0.0)) {
    throw UsageError(std::string("site: ") + what + " is " + std::to_string(v) + ", but must be non-negative");
  }
}

// FNV-1a, 64 bit: a digest, not a security measure.
struct Fnv1a {
  std::uint64_t h = 1469598103934665603ULL;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= c[i];
      h *= 1099511628211ULL;
    }
  }
  void value(double v) { bytes(&v, sizeof v); }
};
}  // namespace

void SiteOptions::validate() const {
  check_nonneg(envelopment_m, "envelopment base length (m)");
  if (!(std::isfinite(unsprung_mass_kg) && unsprung_mass_kg > 0.0)) {
    throw UsageError("site: unsprung mass m1 is " + std::to_string(unsprung_mass_kg) + " kg, but must be positive");
  }
  check_nonneg(suspension_damping_nspm, "suspension damping c_b (N s/m)");
  check_nonneg(tyre_damping_nspm, "tyre damping c_t (N s/m)");
  sensors.validate();
}

void TruckBatch::resize(Eigen::Index n) {
  speed_mps.resize(n);
  sprung_mass_kg.resize(n);
  stiffness_npm.resize(n);
  tyre_stiffness_npm.resize(n);
  lateral_m.resize(n);
}

Site::Site(road::Surface raw_surface, SiteOptions options)
    : surface_(road::envelop((options.validate(), raw_surface), options.envelopment_m)),
      options_(std::move(options)),
      integrator_(make_integrator(surface_, options_.sensors)),
      raw_missing_(road::find_missing(raw_surface)),
      measured_to_m_(std::numeric_limits<double>::infinity()) {
  // The envelopment filter spreads a hole over its window, so the enveloped surface says which
  // samples a pass may read. A pass to x reads the samples up to the one after x (the profile is
  // linear between samples), hence two samples of margin before the first unmeasured one.
  const Eigen::Index first = road::first_row_with_missing(surface_);
  if (first < surface_.samples()) measured_to_m_ = surface_.dx_m * static_cast<double>(first - 2);
  if (!integrator_.positions_m().empty()) check_measured_up_to(integrator_.positions_m().back());
  fingerprint_ = compute_fingerprint();
}

void Site::check_measured_up_to(double x_m) const {
  if (x_m <= measured_to_m_) return;
  std::ostringstream os;
  os << "the trucks' stretch, x = 0 to " << x_m << " m across the whole width (y = " << surface_.y0_m << " to "
     << surface_.y_max_m() << " m, where a truck may drive), crosses missing road: the surface has "
     << road::describe(raw_missing_, surface_)
     << " (missing cells beyond the last sensor are allowed: crop the surface to measured road or move the sensors)";
  throw DataError(surface_.name, 0, "missing cells", os.str());
}

vehicle::WheelPath Site::wheel_path(double lateral_m) const {
  const road::LateralBracket b = road::bracket(surface_, lateral_m);
  return {surface_.line(b.line_a), surface_.line(b.line_b), b.weight_b};
}

vehicle::QuarterCar Site::car(double sprung_mass_kg, double stiffness_npm, double tyre_stiffness_npm) const {
  vehicle::QuarterCar c;
  c.sprung_mass_kg = sprung_mass_kg;
  c.unsprung_mass_kg = options_.unsprung_mass_kg;
  c.suspension_stiffness_npm = stiffness_npm;
  c.suspension_damping_nspm = options_.suspension_damping_nspm;
  c.tyre_stiffness_npm = tyre_stiffness_npm;
  c.tyre_damping_nspm = options_.tyre_damping_nspm;
  return c;
}

void Site::impact_factors(const TruckBatch& trucks, Eigen::Ref<Eigen::ArrayXXd> if_out,
                          Eigen::ArrayXd* min_if) const {
  impact_factors_at(integrator_, trucks, if_out, min_if);
}

void Site::impact_factors_at(const vehicle::PassIntegrator& integrator, const TruckBatch& trucks,
                             Eigen::Ref<Eigen::ArrayXXd> if_out, Eigen::ArrayXd* min_if) const {
  if (!integrator.positions_m().empty()) check_measured_up_to(integrator.positions_m().back());
  const Eigen::Index n = trucks.size();
  const vehicle::QuarterCarBatch cars = this->cars(trucks.sprung_mass_kg, trucks.stiffness_npm, trucks.tyre_stiffness_npm);
  std::vector<vehicle::WheelPath> paths;
  paths.reserve(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) paths.push_back(wheel_path(trucks.lateral_m[i]));
  integrator.run_batch(cars, trucks.speed_mps, paths, if_out, min_if);
}

vehicle::QuarterCarBatch Site::cars(const Eigen::ArrayXd& sprung_mass_kg, const Eigen::ArrayXd& stiffness_npm,
                                    const Eigen::ArrayXd& tyre_stiffness_npm) const {
  const Eigen::Index n = sprung_mass_kg.size();
  vehicle::QuarterCarBatch cars;
  cars.sprung_mass_kg = sprung_mass_kg;
  cars.unsprung_mass_kg = Eigen::ArrayXd::Constant(n, options_.unsprung_mass_kg);
  cars.suspension_stiffness_npm = stiffness_npm;
  cars.suspension_damping_nspm = Eigen::ArrayXd::Constant(n, options_.suspension_damping_nspm);
  cars.tyre_stiffness_npm = tyre_stiffness_npm;
  cars.tyre_damping_nspm = Eigen::ArrayXd::Constant(n, options_.tyre_damping_nspm);
  return cars;
}

vehicle::LineBundle Site::line_bundle(Eigen::Index first_line, Eigen::Index count) const {
  if (first_line < 0 || count < 1 || first_line + count > surface_.lines())
    throw std::out_of_range("Site::line_bundle: lines " + std::to_string(first_line) + " to " +
                            std::to_string(first_line + count - 1) + " are not all on the surface's " +
                            std::to_string(surface_.lines()) + " lines");
  std::vector<const double*> lines;
  for (Eigen::Index l = first_line; l < first_line + count; ++l) lines.push_back(surface_.line(l));
  return vehicle::LineBundle(lines, surface_.samples());
}

void Site::impact_factors_on_lines(double speed_mps, const Eigen::ArrayXd& sprung_mass_kg,
                                   const Eigen::ArrayXd& stiffness_npm, const Eigen::ArrayXd& tyre_stiffness_npm,
                                   const vehicle::LineBundle& lines, Eigen::Ref<Eigen::ArrayXXd> if_out) const {
  if (!integrator_.positions_m().empty()) check_measured_up_to(integrator_.positions_m().back());
  const Eigen::Index n = sprung_mass_kg.size();
  if (stiffness_npm.size() != n || tyre_stiffness_npm.size() != n)
    throw std::invalid_argument("Site::impact_factors_on_lines: sprung_mass_kg, stiffness_npm and tyre_stiffness_npm differ in size");
  integrator_.run_on_lines(cars(sprung_mass_kg, stiffness_npm, tyre_stiffness_npm), speed_mps, lines, if_out);
}

std::string Site::compute_fingerprint() const {
  Fnv1a f;
  f.value(surface_.dx_m);
  f.value(surface_.y0_m);
  f.value(surface_.dy_m);
  const Eigen::Index rows = surface_.samples(), cols = surface_.lines();
  f.bytes(&rows, sizeof rows);
  f.bytes(&cols, sizeof cols);
  f.bytes(surface_.height_m.data(), static_cast<std::size_t>(surface_.height_m.size()) * sizeof(double));
  for (double p : sensor_positions_m()) f.value(p);
  f.value(options_.envelopment_m);
  f.value(options_.unsprung_mass_kg);
  f.value(options_.suspension_damping_nspm);
  f.value(options_.tyre_damping_nspm);
  std::ostringstream os;
  os << std::hex << std::setw(16) << std::setfill('0') << f.h;
  return os.str();
}

}  // namespace ssrfleet::site
