#include "log_arrays.hpp"

#include <optional>
#include <sstream>

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "io/wim_log.hpp"
#include "util/errors.hpp"

namespace py = pybind11;

namespace ssrfleet::python {

std::vector<records::WimRecord> records_of_tuple(const py::tuple& arrays, const SiteHandle& where) {
  const auto truck_id = arrays[0].cast<std::vector<std::string>>();
  const auto time_s = arrays[1].is_none()
                          ? std::nullopt
                          : std::optional<py::array_t<double>>(arrays[1].cast<py::array_t<double>>());
  const auto speed = arrays[2].cast<py::array_t<double>>();
  const auto mass = arrays[3].cast<py::array_t<double>>();
  const auto impact = arrays[4].cast<py::array_t<double>>();
  const auto classes =
      arrays[5].is_none()
          ? std::nullopt
          : std::optional<std::vector<std::string>>(arrays[5].cast<std::vector<std::string>>());
  const auto n = static_cast<py::ssize_t>(truck_id.size());
  if (n < 1) throw DataError("log", 2, "truck_id", "the log holds no truck records");
  if (speed.ndim() != 1 || speed.shape(0) != n)
    throw UsageError("log: speed_mps must hold one number per truck");
  if (mass.ndim() != 1 || mass.shape(0) != n)
    throw UsageError("log: sprung_mass_kg must hold one number per truck");
  if (time_s && (time_s->ndim() != 1 || time_s->shape(0) != n))
    throw UsageError("log: time_s must hold one number per truck");
  if (classes && static_cast<py::ssize_t>(classes->size()) != n)
    throw UsageError("log: class must hold one label per truck");
  if (impact.ndim() != 2 || impact.shape(0) != n)
    throw UsageError("log: impact_factor must be (trucks, sensors)");
  const py::ssize_t m = impact.shape(1);
  if (m != where.site->sensors()) {
    throw DataError("log", 1, "if_" + std::to_string(m),
                    "the log has " + std::to_string(m) + " sensors but the site has " +
                        std::to_string(where.site->sensors()) + " (sensors " + where.flags.sensors + ")");
  }
  std::vector<records::WimRecord> out(static_cast<std::size_t>(n));
  const auto s = speed.unchecked<1>();
  const auto w = mass.unchecked<1>();
  const auto f = impact.unchecked<2>();
  for (py::ssize_t i = 0; i < n; ++i) {
    records::WimRecord& r = out[static_cast<std::size_t>(i)];
    r.truck_id = truck_id[static_cast<std::size_t>(i)];
    if (time_s) r.time_s = time_s->at(i);
    r.speed_mps = s(i);
    r.sprung_mass_kg = w(i);
    r.impact_factor.resize(m);
    for (py::ssize_t j = 0; j < m; ++j) r.impact_factor(j) = f(i, j);
    if (classes) r.vehicle_class = (*classes)[static_cast<std::size_t>(i)];
  }
  return out;
}

std::string log_text(const std::vector<records::WimRecord>& records) {
  std::ostringstream csv;
  io::write_wim_log(csv, records);
  return csv.str();
}

std::vector<records::WimRecord> read_log_arrays(const py::tuple& arrays, const SiteHandle& where,
                                                const io::WimLimits& limits) {
  const std::vector<records::WimRecord> written = records_of_tuple(arrays, where);
  std::stringstream csv(log_text(written));
  io::WimLogReader reader(csv, "log", where.site->options().unsprung_mass_kg, limits);
  std::vector<records::WimRecord> records;
  records::WimRecord r;
  io::Rejection why;
  for (;;) {
    const auto status = reader.next(r, why);
    if (status == io::WimLogReader::Status::end) break;
    if (status == io::WimLogReader::Status::rejected) throw DataError("log", why.line, why.field, why.reason);
    records.push_back(std::move(r));
  }
  if (records.size() != written.size()) {
    throw DataError("log", 2, "truck_id",
                    "the log's rows did not all read back (a truck id with a comma or a newline?)");
  }
  return records;
}

}  // namespace ssrfleet::python
