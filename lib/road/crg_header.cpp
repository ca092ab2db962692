#include "road/crg_header.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <set>

#include "road/road_file.hpp"
#include "util/errors.hpp"

namespace ssrfleet::road {

namespace {

enum class Section { none, comment, road, definition, skipped, file };

// The parameters of $ROAD_CRG that OpenCRG defines.
constexpr std::array<const char*, 28> kRoadParameters = {
    "REFERENCE_LINE_START_U",    "REFERENCE_LINE_END_U",     "REFERENCE_LINE_INCREMENT",
    "LONG_SECTION_V_RIGHT",      "LONG_SECTION_V_LEFT",      "LONG_SECTION_V_INCREMENT",
    "REFERENCE_LINE_START_S",    "REFERENCE_LINE_END_S",     "REFERENCE_LINE_START_B",
    "REFERENCE_LINE_END_B",      "REFERENCE_LINE_START_X",   "REFERENCE_LINE_START_Y",
    "REFERENCE_LINE_END_X",      "REFERENCE_LINE_END_Y",     "REFERENCE_LINE_OFFSET_X",
    "REFERENCE_LINE_OFFSET_Y",   "REFERENCE_LINE_START_PHI", "REFERENCE_LINE_END_PHI",
    "REFERENCE_LINE_OFFSET_PHI", "REFERENCE_LINE_START_Z",   "REFERENCE_LINE_END_Z",
    "REFERENCE_LINE_OFFSET_Z",   "REFERENCE_LINE_START_LON", "REFERENCE_LINE_START_LAT",
    "REFERENCE_LINE_END_LON",    "REFERENCE_LINE_END_LAT",   "REFERENCE_LINE_START_ALT",
    "REFERENCE_LINE_END_ALT"};

std::string upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

// Lower case with runs of blanks collapsed to one space.
std::string normalised(std::string_view s) {
  std::string out;
  for (const char c : trim_blanks(s)) {
    if (c == ' ' || c == '\t') {
      if (!out.empty() && out.back() != ' ') out += ' ';
    } else {
      out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
  }
  return out;
}

bool starts_with(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

CrgChannel parse_channel(std::string_view text, std::size_t line, const std::string& source) {
  CrgChannel ch;
  ch.definition = std::string(trim_blanks(text));
  ch.line = line;
  const std::size_t comma = text.rfind(',');
  if (comma == std::string_view::npos) {
    throw DataError(source, line,
                    "D:", "a channel definition is 'D:name,unit', found 'D:" + ch.definition + "'");
  }
  const std::string name = normalised(text.substr(0, comma));
  const std::string unit = normalised(text.substr(comma + 1));
  const auto need_unit = [&](const std::string& expected) {
    if (unit != expected) {
      throw DataError(source, line, "D:" + ch.definition,
                      "the unit of '" + name + "' must be " + expected + ", found '" + unit + "'");
    }
  };
  if (starts_with(name, "long section")) {
    ch.kind = CrgChannel::Kind::long_section;
    need_unit("m");
    std::string rest(trim_blanks(std::string_view(name).substr(12)));
    if (starts_with(rest, "at v")) {
      const std::size_t eq = rest.find('=');
      if (eq == std::string::npos ||
          !parse_real(trim_blanks(std::string_view(rest).substr(eq + 1)), ch.v_m) || !std::isfinite(ch.v_m)) {
        throw DataError(source, line, "D:" + ch.definition,
                        "a long section's position reads 'at v = <metres>'");
      }
      ch.at_position = true;
    } else {
      double n = 0.0;
      if (!parse_real(rest, n) || !(n >= 1.0 && n == std::floor(n) && n < 1e9)) {
        throw DataError(source, line, "D:" + ch.definition,
                        "a long section is 'long section <number from 1>' or 'long section at v = <metres>'");
      }
      ch.number = static_cast<long>(n);
    }
  } else if (starts_with(name, "reference line")) {
    const std::string what(trim_blanks(std::string_view(name).substr(14)));
    if (what == "phi") {
      ch.kind = CrgChannel::Kind::heading;
      need_unit("rad");
    } else if (what == "banking") {
      ch.kind = CrgChannel::Kind::banking;
      need_unit("m/m");
    } else if (what == "slope") {
      ch.kind = CrgChannel::Kind::slope;
      need_unit("m/m");
    }  // x, y, u: positions of the reference line; read past like any other channel
  }
  return ch;
}

}  // namespace

std::optional<CrgParameter> CrgHeader::parameter(const std::string& key) const {
  const auto it = road.find(key);
  if (it == road.end()) return std::nullopt;
  return it->second;
}

CrgHeader parse_crg_header(std::string_view bytes, const std::string& source) {
  CrgHeader h;
  Section section = Section::none;
  std::set<std::string> seen_sections;
  std::set<std::string> skipped_noted;
  std::size_t pos = 0, number = 0;
  while (pos < bytes.size()) {
    std::string_view line = next_crg_line(bytes, pos);
    ++number;
    line = line.substr(0, crg_header_line_chars);

    if (starts_with(line, "$$")) {
      h.end_line = number;
      h.payload_offset = pos;
      break;
    }
    if (!line.empty() && line.front() == '*') continue;  // block comment
    if (!line.empty() && line.front() == '$') {
      std::string_view keyword = line.substr(1);
      keyword = keyword.substr(0, keyword.find('!'));
      keyword = trim_blanks(keyword);
      keyword = keyword.substr(0, keyword.find_first_of(" \t"));
      if (keyword.empty()) {
        section = Section::none;
        continue;
      }
      const std::string name = upper(keyword);
      if (!seen_sections.insert(name).second) {
        throw DataError(source, number, "$" + name, "the section is given twice (sections are unique)");
      }
      if (name == "CT") {
        section = Section::comment;
      } else if (name == "ROAD_CRG") {
        section = Section::road;
        h.has_road_section = true;
      } else if (name == "KD_DEFINITION") {
        section = Section::definition;
        h.has_definition_section = true;
        h.definition_line = number;
      } else if (name == "ROAD_CRG_FILE") {
        throw DataError(source, number, "$ROAD_CRG_FILE",
                        "references to other OpenCRG files are not read: merge them into one file");
      } else {
        section = Section::skipped;
        if (name == "ROAD_CRG_MODS") {
          h.notes.push_back("the modifiers of $ROAD_CRG_MODS (line " + std::to_string(number) +
                            ") are not applied: the grid is read as stored");
        } else if (name == "ROAD_CRG_OPTS" || name == "ROAD_CRG_MPRO") {
          // evaluation options and the map projection do not change the grid: nothing to say
        } else {
          h.notes.push_back("unknown section $" + name + " (line " + std::to_string(number) + ") read past");
        }
      }
      continue;
    }
    if (section == Section::comment) {
      h.comment.append(line).append("\n");
      continue;
    }
    std::string_view content = line.substr(0, line.find('!'));
    content = trim_blanks(content);
    if (content.empty() || section == Section::none || section == Section::skipped) continue;

    if (section == Section::road) {
      const std::size_t eq = content.find('=');
      if (eq == std::string_view::npos) {
        throw DataError(source, number, "$ROAD_CRG",
                        "expected 'KEY = value', found '" + std::string(content) + "'");
      }
      const std::string key = upper(trim_blanks(content.substr(0, eq)));
      const std::string_view text = trim_blanks(content.substr(eq + 1));
      double value = 0.0;
      if (!parse_real(text, value) || !std::isfinite(value)) {
        throw DataError(source, number, key, "'" + std::string(text) + "' is not a finite number");
      }
      if (std::find(kRoadParameters.begin(), kRoadParameters.end(), key) == kRoadParameters.end()) {
        h.notes.push_back("unknown $ROAD_CRG parameter " + key + " (line " + std::to_string(number) +
                          ") read past");
        continue;
      }
      if (!h.road.emplace(key, CrgParameter{value, number}).second) {
        throw DataError(
            source, number, key,
            "given twice (first on line " + std::to_string(h.road.at(key).line) + "); parameters are unique");
      }
      continue;
    }
    // $KD_DEFINITION
    if (starts_with(content, "#:")) {
      const std::string_view type = trim_blanks(content.substr(2));
      if (!parse_crg_format(type, h.format)) {
        throw DataError(
            source, number, "#:" + std::string(type),
            "unknown data type '" + std::string(type) + "': OpenCRG defines LRFI, LDFI, KRBI and KDBI");
      }
      h.format_line = number;
    } else if (starts_with(content, "D:") || starts_with(content, "d:")) {
      h.channels.push_back(parse_channel(content.substr(2), number, source));
      if (h.channels.back().kind == CrgChannel::Kind::other) {
        h.notes.push_back("channel " + std::to_string(h.channels.size()) + " '" +
                          h.channels.back().definition + "' (line " + std::to_string(number) + ") read past");
      }
    } else if (starts_with(content, "U:") || starts_with(content, "u:")) {
      // a virtual channel: derived, not stored in the payload
    } else {
      throw DataError(
          source, number, "$KD_DEFINITION",
          "expected '#:<data type>', 'D:<channel>,<unit>' or 'U:...', found '" + std::string(content) + "'");
    }
  }
  if (h.end_line == 0) {
    throw DataError(
        source, number, "$$$$",
        "the header never ends: no line starting with $$ before the payload (is this an OpenCRG file?)");
  }
  return h;
}

}  // namespace ssrfleet::road
