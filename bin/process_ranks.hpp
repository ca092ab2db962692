// The processes this run of the command is (docs/sites.md): one for `ssrfleet`
// (bin/process_ranks.cpp), those mpirun started for `ssrfleet-mpi` (mpi/process_ranks_mpi.cpp,
// built with -DSSRFLEET_MPI=ON). main() starts and stops them; `fit` hands them to the marginal core.
#pragma once

#include <string>

#include "util/ranks.hpp"

namespace ssrfleet::cli {

// Before anything else in main (MPI_Init may take its own arguments out of argc/argv).
void start_process_ranks(int* argc, char*** argv);
// Last in main (MPI_Finalize).
void stop_process_ranks();
const util::Ranks& process_ranks();
// After an error that only this rank may have met (a file it could not write): ends every rank
// with this status (MPI_Abort), so none waits forever for it. One process: returns.
void abort_process_ranks(int status);
// "" for one process; " (rank R of S)" to name the rank in a message.
std::string rank_label();

}  // namespace ssrfleet::cli
