// summary.md of `ssrfleet reproduce`: every measured value of the run beside what the paper reports
// for the same figure, one table row each.
#pragma once

#include <cstddef>
#include <ostream>

#include "reproduce/paper_reproduction.hpp"

namespace ssrfleet::reproduce {

// `history_trucks`: how many trucks the streamed fit's history holds (the K interval widths are
// taken after a tenth, a half and all of them).
void write_summary_markdown(std::ostream& os, const Options& o, const Result& res, std::size_t history_trucks);

}  // namespace ssrfleet::reproduce
