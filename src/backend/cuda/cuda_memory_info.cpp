/// Free device memory, for the memory check before the CUDA backend allocates (memory_budget).

#include <cuda_runtime.h>

#include <cstdint>

namespace kfx {

/// Free bytes on the current device (cudaMemGetInfo); 0 when it cannot be read (no check).
uint64_t cuda_free_bytes() {
  size_t free_bytes = 0, total_bytes = 0;
  if (cudaMemGetInfo(&free_bytes, &total_bytes) != cudaSuccess) {
    cudaGetLastError();  // clear the sticky-free error so the backend's own calls report theirs
    return 0;
  }
  return free_bytes;
}

}  // namespace kfx
