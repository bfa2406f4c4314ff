// The MPI ranks of a data-parallel run (Open MPI; `mpirun -np N penumbra render ...`): initialisation
// and shutdown, and the few collectives a distributed frame uses, each counting the bytes this rank
// sends and the time it spends communicating (what `render --stats` reports per rank).
//
// Errors: a rank that fails (a file it cannot read, a bad option, too many ranks for the volume) must
// not leave the others waiting in a collective. Every phase of a distributed command ends with
// agree(), which every rank reaches whatever happened, and which gives all of them the message of the
// lowest failing rank; then they all stop with it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "penumbra/accel/brick_reduction.h"

namespace penumbra {

class MpiWorld final : public BrickReduction {
public:
  // True when this process was started by mpirun/mpiexec (Open MPI, MPICH or PMIx environment).
  static bool launched_by_mpirun();

  // MPI_Init (thread level funneled: only the main thread calls MPI); MPI_Finalize when destroyed.
  MpiWorld(int& argc, char**& argv);
  ~MpiWorld() override;
  MpiWorld(const MpiWorld&) = delete;
  MpiWorld& operator=(const MpiWorld&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  // Ranks on this node (they share its cores), from the launcher; 1 when it does not say.
  int local_size() const { return local_size_; }

  // Every rank passes its error ("" when none); every rank gets "" when none failed, else
  // "rank R of N: <message>" of the lowest failing rank R.
  std::string agree(const std::string& error);
  // Runs f() on this rank, then agree(): an exception on any rank becomes the same Error on all of them.
  void run_agreed(const std::function<void()>& f);

  // For a failure that other ranks cannot be told of through agree() (they may be waiting in a
  // collective the failing rank never reaches): prints "penumbra: error: rank R of N: <message>" and
  // stops every rank (MPI_Abort, exit status 1).
  [[noreturn]] void abort(const std::string& message);
  // Every rank's `values` (the same count on each), concatenated in rank order, on every rank.
  std::vector<int> all_gather(std::span<const int> values);
  // Every rank sends send[counts[0] …) to rank 0, the next counts[1] to rank 1, …; gets back what each
  // rank sent it, in rank order, recv_counts[r] floats from rank r (MPI_Alltoallv).
  void all_to_all(std::span<const float> send, std::span<const int> send_counts, std::span<float> recv,
                  std::span<const int> recv_counts);
  // Rank 0 gets every rank's `send`, concatenated in rank order (counts[r] floats from rank r); `recv`
  // is used on rank 0 only (MPI_Gatherv).
  void gather(std::span<const float> send, std::span<float> recv, std::span<const int> counts);
  // The same for doubles, one value per rank and field (per-rank statistics): rank 0 gets size() ×
  // send.size() values.
  std::vector<double> gather_doubles(std::span<const double> send);
  // values = elementwise minimum over the ranks, on every rank (MPI_Allreduce): how light structures
  // built per brick combine (accel/brick_reduction.h).
  void minimum(std::span<float> values) override;
  // values = elementwise sum over the ranks, on every rank (MPI_Allreduce): histogram counts, and the
  // extinction SAT's per-cell sums.
  void sum(std::span<std::uint64_t> values);
  void sum(std::span<double> values) override;
  // values = the product of the values of the ranks before this one (rank order when increasing_z,
  // else the reverse; ranks hold slabs in order), 1 on the first (MPI_Exscan).
  void exclusive_product(std::span<float> values, bool increasing_z) override;
  // values = elementwise the first candidate over the ranks, on every rank (MPI_Allreduce with a
  // commutative user operation on five floats): the implicit sphere shadow map of a particle scene
  // split by space.
  void nearest(std::span<SphereCandidate> values) override;

  std::size_t bytes_sent() const { return bytes_sent_; }
  double communication_ms() const { return communication_ms_; }

private:
  int rank_ = 0, size_ = 1, local_size_ = 1;
  std::size_t bytes_sent_ = 0;
  double communication_ms_ = 0;
};

}  // namespace penumbra
