// Roads, sites and simulate: the same library calls, defaults and checks as `ssrfleet road`'s
// presets, the site options every command takes, and `ssrfleet simulate`, so that a seed gives the
// very numbers the command writes.
#include <charconv>
#include <iostream>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "fleet/simulator.hpp"
#include "model/fleet_distribution.hpp"
#include "model/model_spec.hpp"
#include "site/road_source.hpp"
#include "site_handle.hpp"
#include "util/errors.hpp"

namespace py = pybind11;

namespace ssrfleet::python {

namespace {
// The most trucks simulate draws, as `ssrfleet simulate` (docs/site-data.md).
constexpr long kMaxSimulatedTrucks = 10'000'000;

RoadHandle load_road(const std::string& name_or_path) {
  RoadHandle r;
  py::gil_scoped_release release;
  r.surface = std::make_shared<const road::Surface>(site::load_road(name_or_path, &std::cerr));
  return r;
}

SiteHandle make_site(const RoadHandle& road, const std::string& sensors, double envelopment_m, double m1_kg,
                     double cb_nspm, double ct_nspm) {
  SiteHandle s;
  s.flags.sensors = sensors;
  s.flags.envelopment_m = envelopment_m;
  s.flags.m1_kg = m1_kg;
  s.flags.cb_nspm = cb_nspm;
  s.flags.ct_nspm = ct_nspm;
  const site::SiteOptions options = s.flags.to_options();
  py::gil_scoped_release release;
  s.site = std::make_shared<const site::Site>(*road.surface, options);
  return s;
}

py::dict simulate(const SiteHandle& where, long trucks, std::uint64_t seed, double noise,
                  const std::string& model, const std::vector<double>& fleet) {
  if (trucks < 1 || trucks > kMaxSimulatedTrucks) {
    throw UsageError("trucks=" + std::to_string(trucks) + ": must be between 1 and " +
                     std::to_string(kMaxSimulatedTrucks));
  }
  if (!(noise >= 0.0)) throw UsageError("noise=" + std::to_string(noise) + ": must be >= 0");
  if (fleet.size() != 10) throw UsageError("the fleet distribution takes 10 numbers");
  fleet::FleetDistribution dist;
  dist.sprung_mass_kg = {fleet[0], fleet[1]};
  dist.stiffness_npm = {fleet[2], fleet[3]};
  dist.tyre_stiffness_npm = {fleet[4], fleet[5]};
  dist.speed_mps = {fleet[6], fleet[7]};
  dist.lateral_m = {fleet[8], fleet[9]};
  const site::Site& site = *where.site;
  fleet::SimulatedLog log;
  {
    py::gil_scoped_release release;
    const std::vector<records::Truck> drawn =
        fleet::draw_fleet(dist, static_cast<int>(trucks), site.lateral_min_m(), site.lateral_max_m(), seed);
    const fleet::SimulationModel setting = fleet::parse_simulation_model(model, site);
    log = setting.extension ? fleet::simulate_log(site, drawn, noise, seed, *setting.extension, setting.psi)
                            : fleet::simulate_log(site, drawn, noise, seed);
  }
  const auto n = static_cast<py::ssize_t>(log.records.size());
  const auto m = static_cast<py::ssize_t>(site.sensors());
  py::array_t<double> speed(n), mass(n), time(n);
  py::array_t<double> impact({n, m});
  py::list ids;
  auto s = speed.mutable_unchecked<1>();
  auto w = mass.mutable_unchecked<1>();
  auto t = time.mutable_unchecked<1>();
  auto f = impact.mutable_unchecked<2>();
  bool with_time = n > 0;
  for (py::ssize_t i = 0; i < n; ++i) {
    const records::WimRecord& r = log.records[static_cast<std::size_t>(i)];
    ids.append(r.truck_id);
    s(i) = r.speed_mps;
    w(i) = r.sprung_mass_kg;
    with_time = with_time && r.time_s.has_value();
    t(i) = r.time_s.value_or(0.0);
    for (py::ssize_t j = 0; j < m; ++j) f(i, j) = r.impact_factor(j);
  }
  py::dict out;
  out["truck_id"] = ids;
  if (with_time) out["time_s"] = time;
  out["speed_mps"] = speed;
  out["sprung_mass_kg"] = mass;
  out["impact_factor"] = impact;
  out["lift_offs"] = log.lift_offs;
  return out;
}
}  // namespace

void bind_sites(py::module_& m) {
  py::class_<RoadHandle>(m, "Road",
                         "A road surface: a preset (AS1, AS2, AS3) or a road file (CSV or OpenCRG).")
      .def_property_readonly("name", [](const RoadHandle& r) { return r.surface->name; })
      .def_property_readonly("length_m", [](const RoadHandle& r) { return r.surface->length_m(); })
      .def("__repr__", [](const RoadHandle& r) { return "<ssrfleet.Road " + r.surface->name + ">"; });
  m.def("_road", &load_road, py::arg("name_or_path"));

  py::class_<SiteHandle>(m, "_Site")
      .def_property_readonly("road_name", [](const SiteHandle& s) { return s.site->surface().name; })
      .def_property_readonly("sensors", [](const SiteHandle& s) { return s.site->sensors(); })
      .def_property_readonly("sensor_positions_m",
                             [](const SiteHandle& s) {
                               const auto& p = s.site->sensor_positions_m();
                               return py::array_t<double>(static_cast<py::ssize_t>(p.size()), p.data());
                             })
      .def_property_readonly("lateral_range_m",
                             [](const SiteHandle& s) {
                               return py::make_tuple(s.site->lateral_min_m(), s.site->lateral_max_m());
                             })
      .def_property_readonly("fingerprint", [](const SiteHandle& s) { return s.site->fingerprint(); })
      .def_property_readonly("sensor_spec", [](const SiteHandle& s) { return s.flags.sensors; })
      .def_property_readonly("envelopment_m", [](const SiteHandle& s) { return s.flags.envelopment_m; })
      .def_property_readonly("m1_kg", [](const SiteHandle& s) { return s.flags.m1_kg; })
      .def_property_readonly("cb_nspm", [](const SiteHandle& s) { return s.flags.cb_nspm; })
      .def_property_readonly("ct_nspm", [](const SiteHandle& s) { return s.flags.ct_nspm; });
  m.def("_make_site", &make_site, py::arg("road"), py::arg("sensors"), py::arg("envelopment_m"),
        py::arg("m1_kg"), py::arg("cb_nspm"), py::arg("ct_nspm"));
  m.def("_simulate", &simulate, py::arg("site"), py::arg("trucks"), py::arg("seed"), py::arg("noise"),
        py::arg("model"), py::arg("fleet"));
}

}  // namespace ssrfleet::python
