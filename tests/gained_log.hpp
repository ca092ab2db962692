// A copy of a simulated log whose PREFIXj columns (if_j or force_j) are multiplied by gains[j - 1],
// each printed with 17 digits so it reads back to the very product: what a miscalibrated sensor
// would have logged (the calibration tests of cli_sites_test and cli_stream_sites_test).
#pragma once

#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace ssrfleet::test {

inline void write_gained_log(const std::string& from, const std::string& to, const std::vector<double>& gains,
                             const std::string& prefix = "if_") {
  std::istringstream in(read_text(from));
  std::string line, out;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') {
      out += line + "\n";
      continue;
    }
    std::vector<std::string> fields;
    std::stringstream ss(line);
    for (std::string f; std::getline(ss, f, ',');) fields.push_back(f);
    if (header.empty()) {
      header = fields;
      out += line + "\n";
      continue;
    }
    for (std::size_t c = 0; c < fields.size(); ++c) {
      if (header[c].rfind(prefix, 0) != 0) continue;
      const std::size_t j = std::stoul(header[c].substr(prefix.size())) - 1;
      char buf[40];
      std::snprintf(buf, sizeof buf, "%.17g", std::stod(fields[c]) * gains.at(j));
      fields[c] = buf;
    }
    std::string joined;
    for (std::size_t c = 0; c < fields.size(); ++c) joined += (c ? "," : "") + fields[c];
    out += joined + "\n";
  }
  write_text(to, out);
}

}  // namespace ssrfleet::test
