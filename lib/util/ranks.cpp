#include "util/ranks.hpp"

namespace ssrfleet::util {

const Ranks& single_rank() {
  static const SingleRank one;
  return one;
}

}  // namespace ssrfleet::util
