#include "cli/mpi_world.h"

#include <mpi.h>

#include <algorithm>
#include <stdexcept>

namespace pt {

MpiWorld::MpiWorld(int* argc, char*** argv) {
  int provided = 0;
  if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
    throw std::runtime_error("MPI_Init_thread failed");
  // Errors return codes instead of aborting inside MPI, so a failed call becomes a message; a rank that dies is
  // still the launcher's to detect (mpirun ends the job: no rank hangs).
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

MpiWorld::~MpiWorld() { MPI_Finalize(); }

void MpiWorld::max_all(std::vector<int64_t>& values) const {
  if (MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_INT64_T, MPI_MAX,
                    MPI_COMM_WORLD) != MPI_SUCCESS)
    throw std::runtime_error("MPI_Allreduce failed");
}

double MpiWorld::sum_all(double value) const {
  double sum = 0.0;
  if (MPI_Allreduce(&value, &sum, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD) != MPI_SUCCESS)
    throw std::runtime_error("MPI_Allreduce failed");
  return sum;
}

std::vector<std::string> MpiWorld::gather_to_root(const std::string& bytes) const {
  // Sizes first, then each rank's bytes in chunks below MPI's int count limit.
  uint64_t size = bytes.size();
  std::vector<uint64_t> sizes(root() ? size_ : 0);
  if (MPI_Gather(&size, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, 0, MPI_COMM_WORLD) != MPI_SUCCESS)
    throw std::runtime_error("MPI_Gather failed");
  constexpr uint64_t kChunk = 1u << 30;
  std::vector<std::string> out;
  if (!root()) {
    for (uint64_t off = 0; off < size; off += kChunk)
      if (MPI_Send(bytes.data() + off, static_cast<int>(std::min(kChunk, size - off)), MPI_BYTE, 0, 1,
                   MPI_COMM_WORLD) != MPI_SUCCESS)
        throw std::runtime_error("MPI_Send failed");
    return out;
  }
  out.resize(size_);
  out[0] = bytes;
  for (int r = 1; r < size_; ++r) {
    out[r].resize(sizes[r]);
    for (uint64_t off = 0; off < sizes[r]; off += kChunk)
      if (MPI_Recv(out[r].data() + off, static_cast<int>(std::min(kChunk, sizes[r] - off)), MPI_BYTE, r, 1,
                   MPI_COMM_WORLD, MPI_STATUS_IGNORE) != MPI_SUCCESS)
        throw std::runtime_error("MPI_Recv from rank " + std::to_string(r) + " failed");
  }
  return out;
}

}  // namespace pt
