#pragma once
/// The device memory policy of a map's storage (map/map_memory.hpp's HostMemory, for GPU
/// memory): device buffers, and whole-buffer fills in stream order on the backend's stream.

#include <cuda_runtime.h>

#include <algorithm>

#include "backend/cuda/cuda_check.hpp"
#include "backend/cuda/cuda_memory.hpp"
#include "map/map_memory.hpp"

namespace kfx::cuda {

/// Sets n elements from `data` to `value` (grid-stride).
template <class T>
__global__ void fill_buffer_kernel(T* data, long long n, T value) {
  for (long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; i < n;
       i += static_cast<long long>(gridDim.x) * blockDim.x) {
    data[i] = value;
  }
}

struct DeviceMemory {
  static constexpr MemoryLocation kLocation = MemoryLocation::kDevice;
  template <class T>
  using Buffer = DeviceBuffer<T>;
  cudaStream_t stream = nullptr;  ///< the fills' stream

  /// Every byte of `buffer` set to `byte` (in stream order).
  template <class T>
  void fill_bytes(const Buffer<T>& buffer, int byte) const {
    if (buffer.size() == 0) return;
    KFX_CUDA_CHECK(cudaMemsetAsync(buffer.data(), byte, buffer.bytes(), stream));
  }
  /// Every element of `buffer` set to `value` (in stream order).
  template <class T>
  void fill(const Buffer<T>& buffer, const T& value) const {
    const long long n = static_cast<long long>(buffer.size());
    if (n == 0) return;
    const unsigned blocks = static_cast<unsigned>(std::min<long long>((n + 255) / 256, 65536));
    fill_buffer_kernel<<<blocks, 256, 0, stream>>>(buffer.data(), n, value);
    KFX_CUDA_CHECK(cudaGetLastError());
  }
};

}  // namespace kfx::cuda
