// A site as Python holds it: the library's Site (shared: a posterior and its predictions keep the
// site they were made with) and the options it was built from, which a log's checks quote.
#pragma once

#include <memory>
#include <string>

#include "cli_common.hpp"
#include "road/surface.hpp"
#include "site/site.hpp"

namespace ssrfleet::python {

// ssrfleet.road(): a loaded road surface, reusable by several sites without reading it again.
struct RoadHandle {
  std::shared_ptr<const road::Surface> surface;
};

struct SiteHandle {
  std::shared_ptr<const site::Site> site;
  cli::SiteFlags flags;
};

}  // namespace ssrfleet::python
