// Which kind of road file a path holds, so that `--road FILE` and `ssrfleet road FILE` read it
// with the right reader: decided by content first (an ERD file starts "ERDFILEV", an OpenCRG
// header's first line that is not a '*' comment starts with '$'), then by extension (.crg, .erd,
// so a damaged file still meets the reader that can say what is wrong with it), else the road CSV.
#pragma once

#include <string>

namespace ssrfleet::road {

enum class RoadFileFormat { csv, crg, erd };

// Missing or unreadable file -> ssrfleet::MissingInputError naming the path.
RoadFileFormat detect_road_format(const std::string& path);

}  // namespace ssrfleet::road
