// The page's files (web/: index.html, app.js, style.css, and Chart.js from Debian's libjs-chart.js),
// compiled into the program by a build step (cmake/web_assets.cmake writes web_assets.cpp), so the
// page works offline and `serve` never opens a file to answer a request: a path either names one
// of these or is a 404, and no path can reach the disk.
#pragma once

#include <string_view>

namespace ssrfleet::serve {

struct WebAsset {
  std::string_view path;          // "/", "/app.js", ...
  std::string_view content_type;  // with charset for text
  std::string_view body;
};

// The asset served at exactly `path`, null if none.
const WebAsset* find_web_asset(std::string_view path);

}  // namespace ssrfleet::serve
