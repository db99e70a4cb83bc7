// The few MPI operations `render --mpi` needs (docs/scale-out.md), so the render loop reads as a plain render:
// rank and size, a per-pass agreement between ranks, and gathering each rank's film state on rank 0. Only the
// main thread calls MPI (MPI_THREAD_FUNNELED); the render threads never do.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace pt {

class MpiWorld {
 public:
  MpiWorld(int* argc, char*** argv);  // MPI_Init_thread; throws std::runtime_error when MPI cannot start
  ~MpiWorld();                        // MPI_Finalize
  MpiWorld(const MpiWorld&) = delete;
  MpiWorld& operator=(const MpiWorld&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool root() const { return rank_ == 0; }

  // Element-wise maximum of `values` over all ranks (every rank gets the result).
  void max_all(std::vector<int64_t>& values) const;
  double sum_all(double value) const;
  // Rank 0 gets every rank's bytes (its own first), in rank order; the others get an empty vector.
  std::vector<std::string> gather_to_root(const std::string& bytes) const;

 private:
  int rank_ = 0, size_ = 1;
};

}  // namespace pt
