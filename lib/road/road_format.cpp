#include "road/road_format.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <string_view>
#include <system_error>

#include "road/road_file.hpp"
#include "util/errors.hpp"

namespace ssrfleet::road {

RoadFileFormat detect_road_format(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw MissingInputError("road file '" + path + "' does not exist or is not a regular file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MissingInputError("cannot open road file '" + path + "'");
  std::string head(4096, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));

  std::string_view rest = head;
  bool first = true;
  while (!rest.empty()) {
    const std::size_t lf = rest.find('\n');
    const std::string_view line = trim_blanks(rest.substr(0, lf));
    rest = lf == std::string_view::npos ? std::string_view{} : rest.substr(lf + 1);
    if (first && line.substr(0, 8) == "ERDFILEV") return RoadFileFormat::erd;
    first = false;
    if (line.empty() || line.front() == '*') continue;
    if (line.front() == '$') return RoadFileFormat::crg;
    break;
  }
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".crg") return RoadFileFormat::crg;
  if (extension == ".erd") return RoadFileFormat::erd;
  return RoadFileFormat::csv;
}

}  // namespace ssrfleet::road
