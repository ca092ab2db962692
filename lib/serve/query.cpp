#include "serve/query.hpp"

#include <charconv>
#include <cmath>
#include <system_error>

namespace ssrfleet::serve {

namespace {

bool is_control(char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; }

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Percent-decoding; '+' is a space (HTML forms). A '%' not followed by two hex digits, or a control
// character (NUL included), sent as it is or encoded, is refused: none has a use in this API, and
// they are the classic ways to smuggle bytes into logs and messages.
std::string decode(std::string_view text, const std::string& parameter) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '%') {
      const bool two_follow = i + 2 < text.size();
      const int hi = two_follow ? hex_digit(text[i + 1]) : -1;
      const int lo = two_follow ? hex_digit(text[i + 2]) : -1;
      if (hi < 0 || lo < 0) throw QueryError(parameter, "a '%' must be followed by two hexadecimal digits");
      const char decoded = static_cast<char>(hi * 16 + lo);
      if (is_control(decoded))
        throw QueryError(parameter, "control characters (such as %00) are not allowed");
      out.push_back(decoded);
      i += 2;
    } else if (is_control(c)) {
      throw QueryError(parameter, "control characters are not allowed");
    } else if (c == '+') {
      out.push_back(' ');
    } else {
      out.push_back(c);
    }
  }
  return out;
}

bool valid_name(std::string_view name) {
  if (name.empty() || name.size() > 32) return false;
  for (const char c : name) {
    if (!((c >= 'a' && c <= 'z') || c == '_')) return false;
  }
  return true;
}

double finite_number(const std::string& parameter, std::string_view text) {
  double v = 0.0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (ec != std::errc() || ptr != end || !std::isfinite(v)) {
    throw QueryError(parameter, "'" + std::string(text.substr(0, 40)) + "' is not a finite number");
  }
  return v;
}

}  // namespace

Query Query::parse(std::string_view raw) {
  if (raw.size() > kMaxQueryBytes) {
    throw QueryError("query", "the query string is " + std::to_string(raw.size()) + " bytes, more than the " +
                                  std::to_string(kMaxQueryBytes) + " allowed");
  }
  Query q;
  std::size_t start = 0;
  while (start <= raw.size() && !raw.empty()) {
    std::size_t amp = raw.find('&', start);
    if (amp == std::string_view::npos) amp = raw.size();
    const std::string_view item = raw.substr(start, amp - start);
    start = amp + 1;
    if (!item.empty()) {
      const std::size_t eq = item.find('=');
      const std::string_view raw_name = item.substr(0, eq);
      if (!valid_name(raw_name)) {
        // The name itself is bad: report a printable prefix of it, never more than 32 bytes.
        std::string shown;
        for (const char c : raw_name.substr(0, 32)) shown.push_back(c >= 0x20 && c < 0x7f ? c : '?');
        throw QueryError(shown.empty() ? "query" : shown,
                         "a parameter name is 1 to 32 lower-case letters or '_'");
      }
      const std::string name(raw_name);
      for (const auto& [have, value] : q.parameters_) {
        if (have == name) throw QueryError(name, "given more than once");
      }
      if (q.parameters_.size() == kMaxParameters) {
        throw QueryError(name, "more than " + std::to_string(kMaxParameters) + " parameters");
      }
      std::string value = eq == std::string_view::npos ? std::string() : decode(item.substr(eq + 1), name);
      if (value.size() > kMaxValueBytes) {
        throw QueryError(name, "the value is longer than " + std::to_string(kMaxValueBytes) + " bytes");
      }
      q.parameters_.emplace_back(name, std::move(value));
    }
    if (amp == raw.size()) break;
  }
  return q;
}

void Query::only(std::initializer_list<std::string_view> allowed) const {
  for (const auto& [name, value] : parameters_) {
    bool known = false;
    for (const std::string_view a : allowed) known = known || a == name;
    if (!known) {
      std::string list;
      for (const std::string_view a : allowed) list.append(list.empty() ? "" : ", ").append(a);
      throw QueryError(name,
                       "unknown parameter here (this path takes: " + (list.empty() ? "none" : list) + ")");
    }
  }
}

std::optional<std::string> Query::get(std::string_view name) const {
  for (const auto& [have, value] : parameters_) {
    if (have == name) return value;
  }
  return std::nullopt;
}

std::int64_t Query::integer(std::string_view name, std::int64_t fallback, std::int64_t min,
                            std::int64_t max) const {
  const auto text = get(name);
  if (!text) return fallback;
  std::int64_t v = 0;
  const char* end = text->data() + text->size();
  const auto [ptr, ec] = std::from_chars(text->data(), end, v);
  if (ec != std::errc() || ptr != end || text->empty()) {
    throw QueryError(std::string(name), "'" + text->substr(0, 40) + "' is not a whole number");
  }
  if (v < min || v > max) {
    throw QueryError(std::string(name), std::to_string(v) + " is outside [" + std::to_string(min) + ", " +
                                            std::to_string(max) + "]");
  }
  return v;
}

std::optional<std::string> Query::label(std::string_view name) const {
  auto text = get(name);
  if (!text || text->empty()) return std::nullopt;
  bool ok = text->size() <= 64;
  for (const char c : *text) {
    ok = ok && ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
                c == '.' || c == '-');
  }
  if (!ok) throw QueryError(std::string(name), "a name is 1 to 64 of A-Z a-z 0-9 _ . -");
  return text;
}

std::vector<double> Query::positions(std::string_view name) const {
  const auto text = get(name);
  if (!text || text->empty()) return {};
  return parse_positions_value(std::string(name), *text);
}

std::vector<double> parse_positions_value(const std::string& parameter, std::string_view text) {
  std::vector<double> p;
  const std::size_t colon = text.find(':');
  if (colon != std::string_view::npos) {
    const std::size_t colon2 = text.find(':', colon + 1);
    if (colon2 == std::string_view::npos || text.find(':', colon2 + 1) != std::string_view::npos) {
      throw QueryError(parameter, "expected FIRST:STEP:LAST (metres)");
    }
    const double first = finite_number(parameter, text.substr(0, colon));
    const double step = finite_number(parameter, text.substr(colon + 1, colon2 - colon - 1));
    const double last = finite_number(parameter, text.substr(colon2 + 1));
    if (!(step > 0.0) || last < first) throw QueryError(parameter, "need STEP > 0 and LAST >= FIRST");
    // Counted as a double before any cast: a huge LAST / STEP is refused, not overflowed.
    const double count = std::floor((last - first) / step + 1e-9) + 1.0;
    if (!(count <= static_cast<double>(kMaxPositions))) {
      throw QueryError(parameter, "more than " + std::to_string(kMaxPositions) + " positions");
    }
    const auto n = static_cast<long>(count);
    for (long i = 0; i < n; ++i) p.push_back(first + static_cast<double>(i) * step);
    return p;
  }
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t comma = text.find(',', start);
    if (comma == std::string_view::npos) comma = text.size();
    if (p.size() == kMaxPositions)
      throw QueryError(parameter, "more than " + std::to_string(kMaxPositions) + " positions");
    p.push_back(finite_number(parameter, text.substr(start, comma - start)));
    if (p.size() > 1 && !(p.back() > p[p.size() - 2])) {
      throw QueryError(parameter, "positions must be strictly increasing");
    }
    start = comma + 1;
  }
  return p;
}

}  // namespace ssrfleet::serve
