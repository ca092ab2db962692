// ssrfleet-mpi: the processes mpirun started, each one rank of MPI_COMM_WORLD.
#include <memory>
#include <stdexcept>

#include <mpi.h>

#include "../bin/process_ranks.hpp"
#include "mpi_ranks.hpp"

namespace ssrfleet::cli {

namespace {
std::unique_ptr<mpi::MpiRanks>& ranks() {
  static std::unique_ptr<mpi::MpiRanks> r;
  return r;
}
}  // namespace

void start_process_ranks(int* argc, char*** argv) {
  // One thread calls MPI (the SMC's worker threads never do: collectives run between the loops).
  int provided = 0;
  if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
    throw std::runtime_error("MPI_Init_thread failed");
  }
  if (provided < MPI_THREAD_FUNNELED) {
    MPI_Finalize();
    throw std::runtime_error("this MPI gives no thread support (MPI_THREAD_FUNNELED); ssrfleet-mpi needs it");
  }
  ranks() = std::make_unique<mpi::MpiRanks>();
}

void stop_process_ranks() {
  ranks().reset();
  MPI_Finalize();
}

const util::Ranks& process_ranks() { return *ranks(); }

void abort_process_ranks(int status) {
  if (ranks() && ranks()->size() > 1) MPI_Abort(MPI_COMM_WORLD, status);
}

std::string rank_label() {
  if (!ranks() || ranks()->size() == 1) return "";
  return " (rank " + std::to_string(ranks()->rank()) + " of " + std::to_string(ranks()->size()) + ")";
}

}  // namespace ssrfleet::cli
