// A posterior as Python holds it (ssrfleet.Posterior wraps one): a fit's, diagnose's or a file's.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "fleet/vehicle_classes.hpp"
#include "records/wim_record.hpp"
#include "site/site.hpp"

namespace ssrfleet::python {

struct PosteriorHandle {
  fleet::ClassPosteriors classes;
  // What the fit had (a posterior read from a file has neither): the site predict defaults to, and
  // the log the NetCDF draws carry as observed data.
  std::shared_ptr<const site::Site> site;
  std::vector<records::WimRecord> records;
  std::uint64_t seed = 1;
  std::string source = "the result of ssrfleet.fit()";  // a file's path: how messages name it
  // The posterior file as the command wrote it, when a fit here went through the command's file
  // (fit of a manifest's sites): to_json writes these bytes.
  std::string file_text;
};

}  // namespace ssrfleet::python
