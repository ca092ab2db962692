#include "road/roughness_class.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "util/check.hpp"

namespace ssrfleet::road {

namespace {
// Upper bounds of every class but the last (x 1e-6 m^3); class k spans [bound k-1, bound k).
constexpr std::array<double, 7> kIso8608Upper = {32, 128, 512, 2048, 8192, 32768, 131072};
constexpr std::array<double, 4> kDraftUpper = {8, 32, 128, 512};

template <std::size_t N>
RoughnessClass classify(double gd_n0_m3, const std::array<double, N>& upper_e6, std::string table) {
  RoughnessClass c;
  c.table = std::move(table);
  std::size_t k = 0;
  while (k < N && gd_n0_m3 >= upper_e6[k] * 1e-6) ++k;
  c.label = std::string(1, static_cast<char>('A' + k));
  c.lower_m3 = k == 0 ? 0.0 : upper_e6[k - 1] * 1e-6;
  c.upper_m3 = k == N ? std::numeric_limits<double>::infinity() : upper_e6[k] * 1e-6;
  return c;
}
}  // namespace

RoughnessClass roughness_class(double gd_n0_m3, RoughnessTable table) {
  check_positive("roughness_class", "gd_n0_m3", gd_n0_m3);
  if (table == RoughnessTable::iso8608_1995) return classify(gd_n0_m3, kIso8608Upper, table_name(table));
  return classify(gd_n0_m3, kDraftUpper, table_name(table));
}

RoughnessTable parse_roughness_table(std::string_view name) {
  if (name == "iso8608") return RoughnessTable::iso8608_1995;
  if (name == "paper" || name == "iso-draft-1982") return RoughnessTable::iso_draft_1982;
  throw std::invalid_argument(
      "unknown roughness class table '" + std::string(name) +
      "': use iso8608 (ISO 8608:1995) or paper (the ISO draft of 1982 the paper's labels follow)");
}

std::string table_name(RoughnessTable table) {
  return table == RoughnessTable::iso8608_1995 ? "ISO 8608:1995" : "ISO draft 1982 (the paper's classes)";
}

}  // namespace ssrfleet::road
