#include "mpi_ranks.hpp"

#include <algorithm>
#include <climits>
#include <stdexcept>
#include <string>
#include <vector>

#include <mpi.h>

namespace ssrfleet::mpi {

namespace {

void check(int code, const char* what) {
  if (code != MPI_SUCCESS) throw std::runtime_error(std::string("MPI: ") + what + " failed");
}

// The reduction of exact sums in word form (util::ExactSum::add_words): integer additions, so the
// order MPI applies them in does not change the result.
void add_exact_sums(void* in, void* inout, int* len, MPI_Datatype*) {
  const auto* from = static_cast<const std::uint64_t*>(in);
  auto* into = static_cast<std::uint64_t*>(inout);
  for (int i = 0; i < *len; ++i) util::ExactSum::add_words(from + i * util::ExactSum::kWords, into + i * util::ExactSum::kWords);
}

// MPI counts are int: a payload above INT_MAX bytes is sent in pieces.
constexpr std::size_t kPiece = std::size_t{1} << 30;

}  // namespace

struct MpiRanks::Handles {
  MPI_Datatype exact_sum = MPI_DATATYPE_NULL;
  MPI_Op add = MPI_OP_NULL;
};

MpiRanks::MpiRanks() : handles_(new Handles) {
  check(MPI_Comm_rank(MPI_COMM_WORLD, &rank_), "MPI_Comm_rank");
  check(MPI_Comm_size(MPI_COMM_WORLD, &size_), "MPI_Comm_size");
  check(MPI_Type_contiguous(util::ExactSum::kWords, MPI_UINT64_T, &handles_->exact_sum), "MPI_Type_contiguous");
  check(MPI_Type_commit(&handles_->exact_sum), "MPI_Type_commit");
  check(MPI_Op_create(&add_exact_sums, /*commute=*/1, &handles_->add), "MPI_Op_create");
}

MpiRanks::~MpiRanks() {
  MPI_Op_free(&handles_->add);
  MPI_Type_free(&handles_->exact_sum);
  delete handles_;
}

void MpiRanks::sum(util::ExactSum* sums, std::size_t count) const {
  if (size_ == 1 || count == 0) return;
  std::vector<std::uint64_t> words(count * util::ExactSum::kWords);
  for (std::size_t i = 0; i < count; ++i) sums[i].to_words(&words[i * util::ExactSum::kWords]);
  const std::size_t per_piece = kPiece / (util::ExactSum::kWords * sizeof(std::uint64_t));
  for (std::size_t first = 0; first < count; first += per_piece) {
    const std::size_t n = std::min(per_piece, count - first);
    check(MPI_Allreduce(MPI_IN_PLACE, &words[first * util::ExactSum::kWords], static_cast<int>(n), handles_->exact_sum,
                        handles_->add, MPI_COMM_WORLD),
          "MPI_Allreduce of the log-likelihood sums");
  }
  for (std::size_t i = 0; i < count; ++i) sums[i] = util::ExactSum::from_words(&words[i * util::ExactSum::kWords]);
  ++traffic_.calls;
  traffic_.bytes += words.size() * sizeof(std::uint64_t);
}

void MpiRanks::broadcast(void* data, std::size_t bytes, int root) const {
  if (size_ == 1 || bytes == 0) return;
  auto* p = static_cast<char*>(data);
  for (std::size_t first = 0; first < bytes; first += kPiece) {
    check(MPI_Bcast(p + first, static_cast<int>(std::min(kPiece, bytes - first)), MPI_BYTE, root, MPI_COMM_WORLD),
          "MPI_Bcast");
  }
  ++traffic_.calls;
  if (rank_ == root) traffic_.bytes += bytes;
}

std::vector<std::string> MpiRanks::gather(const std::string& mine, int root) const {
  if (size_ == 1) return {mine};
  // Sizes first, then each rank's bytes to the root (point to point: a checkpoint's pieces can
  // exceed what one MPI_Gatherv's int displacements address).
  const std::uint64_t length = mine.size();
  std::vector<std::uint64_t> lengths(rank_ == root ? static_cast<std::size_t>(size_) : 0);
  check(MPI_Gather(&length, 1, MPI_UINT64_T, lengths.data(), 1, MPI_UINT64_T, root, MPI_COMM_WORLD), "MPI_Gather");
  ++traffic_.calls;
  if (rank_ != root) {
    for (std::size_t first = 0; first < mine.size(); first += kPiece) {
      check(MPI_Send(mine.data() + first, static_cast<int>(std::min(kPiece, mine.size() - first)), MPI_BYTE, root, 0,
                     MPI_COMM_WORLD),
            "MPI_Send");
    }
    traffic_.bytes += mine.size();
    return {};
  }
  std::vector<std::string> all(static_cast<std::size_t>(size_));
  for (int r = 0; r < size_; ++r) {
    if (r == root) {
      all[static_cast<std::size_t>(r)] = mine;
      continue;
    }
    std::string& s = all[static_cast<std::size_t>(r)];
    s.resize(lengths[static_cast<std::size_t>(r)]);
    for (std::size_t first = 0; first < s.size(); first += kPiece) {
      check(MPI_Recv(s.data() + first, static_cast<int>(std::min(kPiece, s.size() - first)), MPI_BYTE, r, 0,
                     MPI_COMM_WORLD, MPI_STATUS_IGNORE),
            "MPI_Recv");
    }
  }
  return all;
}

void MpiRanks::share_slices(double* values, std::size_t count) const {
  if (size_ == 1 || count == 0) return;
  if (count > static_cast<std::size_t>(INT_MAX)) throw std::runtime_error("MPI: share_slices of more than INT_MAX values");
  std::vector<int> counts(static_cast<std::size_t>(size_)), offsets(static_cast<std::size_t>(size_));
  for (int r = 0; r < size_; ++r) {
    const auto [first, last] = slice_of(r, count);
    counts[static_cast<std::size_t>(r)] = static_cast<int>(last - first);
    offsets[static_cast<std::size_t>(r)] = static_cast<int>(first);
  }
  check(MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DOUBLE, values, counts.data(), offsets.data(), MPI_DOUBLE,
                       MPI_COMM_WORLD),
        "MPI_Allgatherv of the newest truck's likelihoods");
  ++traffic_.calls;
  traffic_.bytes += static_cast<std::uint64_t>(counts[static_cast<std::size_t>(rank_)]) * sizeof(double);
}

}  // namespace ssrfleet::mpi
