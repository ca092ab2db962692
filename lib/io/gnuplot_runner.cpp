#include "io/gnuplot_runner.hpp"

#include <cstdlib>
#include <filesystem>
#include <sstream>

#include <unistd.h>

namespace ssrfleet::io {

std::string png_and_svg_script(const std::string& name, const std::string& body, int width, int height) {
  std::ostringstream s;
  s << "# " << name << ": written by ssrfleet reproduce; run `gnuplot " << name << ".gp` in this folder\n"
    << "set datafile separator ','\n"
    << "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {\n"
    << "  set terminal pngcairo size " << width << "," << height << " enhanced font 'sans,11' dashed\n"
    << "} else {\n"
    << "  set terminal png size " << width << "," << height << "\n"
    << "}\n"
    << "set output '" << name << ".png'\n"
    << body << "unset output\n"
    << "set terminal svg size " << width << "," << height << " enhanced font 'sans,11' dynamic\n"
    << "set output '" << name << ".svg'\n"
    << body << "unset output\n";
  return s.str();
}

bool gnuplot_available() {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::stringstream ss(path);
  std::string dir;
  while (std::getline(ss, dir, ':')) {
    if (dir.empty()) continue;
    const auto candidate = std::filesystem::path(dir) / "gnuplot";
    if (::access(candidate.c_str(), X_OK) == 0) return true;
  }
  return false;
}

std::vector<std::string> run_gnuplot(const std::string& dir, const std::vector<PlotScript>& scripts) {
  std::vector<std::string> failed;
  std::string quoted = "'";
  for (char c : dir) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  quoted += "'";
  for (const auto& s : scripts) {
    const std::string cmd = "cd " + quoted + " && gnuplot " + s.name + ".gp >/dev/null 2>" + s.name + ".gnuplot.log";
    if (std::system(cmd.c_str()) != 0) {
      failed.push_back(s.name);
    } else {
      std::error_code ec;
      std::filesystem::remove(std::filesystem::path(dir) / (s.name + ".gnuplot.log"), ec);
    }
  }
  return failed;
}

}  // namespace ssrfleet::io
