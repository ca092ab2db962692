// ssrfleet: one process (the MPI build's ssrfleet-mpi links mpi/process_ranks_mpi.cpp instead).
#include "process_ranks.hpp"

namespace ssrfleet::cli {

void start_process_ranks(int*, char***) {}
void stop_process_ranks() {}
const util::Ranks& process_ranks() { return util::single_rank(); }
void abort_process_ranks(int) {}
std::string rank_label() { return ""; }

}  // namespace ssrfleet::cli
