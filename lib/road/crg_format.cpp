#include "road/crg_format.hpp"

#include <array>
#include <cctype>
#include <utility>

namespace ssrfleet::road {

namespace {
constexpr std::array<std::pair<const char*, CrgDataFormat>, 4> kFormats = {{{"LRFI", CrgDataFormat::lrfi},
                                                                            {"LDFI", CrgDataFormat::ldfi},
                                                                            {"KRBI", CrgDataFormat::krbi},
                                                                            {"KDBI", CrgDataFormat::kdbi}}};
}

std::string crg_format_name(CrgDataFormat f) {
  for (const auto& [name, format] : kFormats) {
    if (format == f) return name;
  }
  return "?";
}

bool parse_crg_format(std::string_view name, CrgDataFormat& f) {
  std::string upper(name);
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  for (const auto& [known, format] : kFormats) {
    if (upper == known) {
      f = format;
      return true;
    }
  }
  return false;
}

}  // namespace ssrfleet::road
