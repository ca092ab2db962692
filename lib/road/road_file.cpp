#include "road/road_file.hpp"

#include <unistd.h>

#include <charconv>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <system_error>

#include "util/errors.hpp"

namespace ssrfleet::road {

std::string read_whole_file(const std::string& path, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw MissingInputError(what + " '" + path + "' does not exist or is not a regular file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MissingInputError("cannot open " + what + " '" + path + "'");
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw MissingInputError("cannot read " + what + " '" + path + "'");
  return bytes;
}

void write_file_atomically(const std::string& path, const std::string& what,
                           const std::function<void(std::ostream&)>& write) {
  const std::string temporary = path + ".tmp." + std::to_string(::getpid());
  const auto discard = [&temporary] {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
  };
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw IoError("cannot write " + what + " '" + path + "' (cannot create '" + temporary + "')");
    try {
      write(out);
    } catch (...) {
      out.close();
      discard();
      throw;
    }
    out.close();
    if (!out) {
      discard();
      throw IoError("writing " + what + " '" + path + "' failed");
    }
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    discard();
    throw IoError("cannot write " + what + " '" + path + "': " + ec.message());
  }
}

std::string_view trim_blanks(std::string_view s) {
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

bool parse_real(std::string_view text, double& value) {
  if (text.empty() || text.size() > 64) return false;
  char buffer[65];
  std::size_t n = 0;
  for (const char c : text) buffer[n++] = (c == 'D' || c == 'd') ? 'e' : c;
  const char* begin = buffer;
  if (*begin == '+') ++begin;  // from_chars takes no leading '+'
  if (begin != buffer && begin < buffer + n && (*begin == '+' || *begin == '-')) return false;
  const auto [ptr, ec] = std::from_chars(begin, buffer + n, value);
  return ec == std::errc() && ptr == buffer + n && begin != buffer + n;
}

std::string shortest_decimal(double value) {
  char buffer[32];
  const auto [ptr, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, ptr);
}

}  // namespace ssrfleet::road
