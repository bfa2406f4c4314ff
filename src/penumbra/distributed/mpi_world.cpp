#include "penumbra/distributed/mpi_world.h"

// The C API only: Open MPI's and MPICH's mpi.h otherwise pull in the deprecated C++ bindings.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <numeric>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"

namespace penumbra {
namespace {

int env_int(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::atoi(v) : fallback;
}

void check(int code, const char* what) {
  if (code != MPI_SUCCESS) throw Error(std::string("MPI: ") + what + " failed (code " + std::to_string(code) + ")");
}

std::size_t sum_except(std::span<const int> counts, int skip) {
  std::size_t n = 0;
  for (std::size_t r = 0; r < counts.size(); ++r)
    if (static_cast<int>(r) != skip) n += static_cast<std::size_t>(counts[r]);
  return n;
}

// What recursive doubling sends for an allreduce or a scan: the whole array once per round, ⌈log2 N⌉
// rounds.
int rounds(int ranks) {
  int r = 0;
  while ((1 << r) < ranks) ++r;
  return r;
}

std::vector<int> displacements(std::span<const int> counts) {
  std::vector<int> d(counts.size(), 0);
  for (std::size_t r = 1; r < counts.size(); ++r) d[r] = d[r - 1] + counts[r - 1];
  return d;
}

}  // namespace

bool MpiWorld::launched_by_mpirun() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"})
    if (std::getenv(name) != nullptr) return true;
  return false;
}

MpiWorld::MpiWorld(int& argc, char**& argv) {
  int provided = 0;
  check(MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  local_size_ = std::max(1, env_int("OMPI_COMM_WORLD_LOCAL_SIZE", env_int("MPI_LOCALNRANKS", 1)));
}

MpiWorld::~MpiWorld() { MPI_Finalize(); }

void MpiWorld::abort(const std::string& message) {
  std::fprintf(stderr, "penumbra: error: rank %d of %d: %s (stopping every rank)\n", rank_, size_, message.c_str());
  std::fflush(stderr);
  MPI_Abort(MPI_COMM_WORLD, 1);
  std::_Exit(1);  // MPI_Abort does not return; should it, this rank still stops
}

void MpiWorld::run_agreed(const std::function<void()>& f) {
  std::string error;
  try {
    f();
  } catch (const std::exception& e) {
    error = e.what();
    if (error.empty()) error = "unknown error";
  }
  error = agree(error);
  if (!error.empty()) throw Error(error);
}

std::string MpiWorld::agree(const std::string& error) {
  Timer t;
  const int mine = static_cast<int>(error.size());
  std::vector<int> lengths(static_cast<std::size_t>(size_));
  check(MPI_Allgather(&mine, 1, MPI_INT, lengths.data(), 1, MPI_INT, MPI_COMM_WORLD), "MPI_Allgather");
  bytes_sent_ += sizeof(int) * static_cast<std::size_t>(size_ - 1);
  int failing = -1;
  for (int r = 0; r < size_ && failing < 0; ++r)
    if (lengths[static_cast<std::size_t>(r)] > 0) failing = r;
  std::string message;
  if (failing >= 0) {
    std::string text = rank_ == failing ? error : std::string(static_cast<std::size_t>(lengths[static_cast<std::size_t>(failing)]), ' ');
    check(MPI_Bcast(text.data(), static_cast<int>(text.size()), MPI_CHAR, failing, MPI_COMM_WORLD), "MPI_Bcast");
    if (rank_ == failing) bytes_sent_ += text.size();
    message = "rank " + std::to_string(failing) + " of " + std::to_string(size_) + ": " + text;
  }
  communication_ms_ += t.elapsed_ms();
  return message;
}

std::vector<int> MpiWorld::all_gather(std::span<const int> values) {
  Timer t;
  std::vector<int> all(values.size() * static_cast<std::size_t>(size_));
  check(MPI_Allgather(values.data(), static_cast<int>(values.size()), MPI_INT, all.data(), static_cast<int>(values.size()), MPI_INT,
                      MPI_COMM_WORLD),
        "MPI_Allgather");
  bytes_sent_ += values.size() * sizeof(int) * static_cast<std::size_t>(size_ - 1);
  communication_ms_ += t.elapsed_ms();
  return all;
}

void MpiWorld::all_to_all(std::span<const float> send, std::span<const int> send_counts, std::span<float> recv,
                          std::span<const int> recv_counts) {
  Timer t;
  const std::vector<int> sd = displacements(send_counts), rd = displacements(recv_counts);
  check(MPI_Alltoallv(send.data(), send_counts.data(), sd.data(), MPI_FLOAT, recv.data(), recv_counts.data(), rd.data(), MPI_FLOAT,
                      MPI_COMM_WORLD),
        "MPI_Alltoallv");
  bytes_sent_ += sum_except(send_counts, rank_) * sizeof(float);
  communication_ms_ += t.elapsed_ms();
}

void MpiWorld::gather(std::span<const float> send, std::span<float> recv, std::span<const int> counts) {
  Timer t;
  const std::vector<int> d = displacements(counts);
  check(MPI_Gatherv(send.data(), static_cast<int>(send.size()), MPI_FLOAT, recv.data(), counts.data(), d.data(), MPI_FLOAT, 0,
                    MPI_COMM_WORLD),
        "MPI_Gatherv");
  if (rank_ != 0) bytes_sent_ += send.size() * sizeof(float);
  communication_ms_ += t.elapsed_ms();
}

std::vector<double> MpiWorld::gather_doubles(std::span<const double> send) {
  Timer t;
  std::vector<double> all(rank_ == 0 ? send.size() * static_cast<std::size_t>(size_) : 0);
  check(MPI_Gather(send.data(), static_cast<int>(send.size()), MPI_DOUBLE, all.data(), static_cast<int>(send.size()), MPI_DOUBLE, 0,
                   MPI_COMM_WORLD),
        "MPI_Gather");
  if (rank_ != 0) bytes_sent_ += send.size() * sizeof(double);
  communication_ms_ += t.elapsed_ms();
  return all;
}

void MpiWorld::minimum(std::span<float> data) {
  Timer t;
  check(MPI_Allreduce(MPI_IN_PLACE, data.data(), static_cast<int>(data.size()), MPI_FLOAT, MPI_MIN, MPI_COMM_WORLD), "MPI_Allreduce");
  bytes_sent_ += data.size() * sizeof(float) * static_cast<std::size_t>(rounds(size_));
  communication_ms_ += t.elapsed_ms();
}

void MpiWorld::sum(std::span<std::uint64_t> values) {
  Timer t;
  check(MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD),
        "MPI_Allreduce");
  bytes_sent_ += values.size() * sizeof(std::uint64_t) * static_cast<std::size_t>(rounds(size_));
  communication_ms_ += t.elapsed_ms();
}

void MpiWorld::sum(std::span<double> values) {
  Timer t;
  check(MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD), "MPI_Allreduce");
  bytes_sent_ += values.size() * sizeof(double) * static_cast<std::size_t>(rounds(size_));
  communication_ms_ += t.elapsed_ms();
}

void MpiWorld::exclusive_product(std::span<float> values, bool increasing_z) {
  Timer t;
  MPI_Comm comm = MPI_COMM_WORLD;
  if (!increasing_z)  // the ranks in reverse order
    check(MPI_Comm_split(MPI_COMM_WORLD, 0, size_ - 1 - rank_, &comm), "MPI_Comm_split");
  std::vector<float> in(values.begin(), values.end());
  check(MPI_Exscan(in.data(), values.data(), static_cast<int>(values.size()), MPI_FLOAT, MPI_PROD, comm), "MPI_Exscan");
  int position = 0;
  MPI_Comm_rank(comm, &position);
  if (position == 0) std::fill(values.begin(), values.end(), 1.0f);  // MPI leaves the first rank's undefined
  if (!increasing_z) MPI_Comm_free(&comm);
  bytes_sent_ += values.size() * sizeof(float) * static_cast<std::size_t>(rounds(size_));
  communication_ms_ += t.elapsed_ms();
}

namespace {

void first_candidate(void* in, void* inout, int* count, MPI_Datatype*) {
  const auto* a = static_cast<const SphereCandidate*>(in);
  auto* b = static_cast<SphereCandidate*>(inout);
  for (int i = 0; i < *count; ++i)
    if (a[i].before(b[i])) b[i] = a[i];
}

}  // namespace

void MpiWorld::nearest(std::span<SphereCandidate> values) {
  Timer t;
  MPI_Datatype candidate;
  check(MPI_Type_contiguous(5, MPI_FLOAT, &candidate), "MPI_Type_contiguous");
  check(MPI_Type_commit(&candidate), "MPI_Type_commit");
  MPI_Op first;
  check(MPI_Op_create(&first_candidate, 1, &first), "MPI_Op_create");
  check(MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), candidate, first, MPI_COMM_WORLD), "MPI_Allreduce");
  MPI_Op_free(&first);
  MPI_Type_free(&candidate);
  bytes_sent_ += values.size() * sizeof(SphereCandidate) * static_cast<std::size_t>(rounds(size_));
  communication_ms_ += t.elapsed_ms();
}

}  // namespace penumbra
