#pragma once
/// GPU mesh extraction (kernels/marching_cubes.hpp) for the CUDA backend: brick flags, the
/// count pass over active bricks, compaction by two CUB scans (vertices per run of 8 voxels,
/// triangles per column segment), the write pass, then one copy of each array into pinned host
/// memory. Every buffer is reused across calls and only grows; one synchronisation reads the
/// totals, one waits for the copy.

#include <cuda_runtime.h>

#include <cstdint>

#include "backend/cuda/cuda_memory.hpp"
#include "core/mesh.hpp"
#include "core/volume.hpp"
#include "kernels/marching_cubes.hpp"

namespace kfx::cuda {

class MeshExtractor {
 public:
  /// Allocates the scratch a res³ volume needs (the mesh itself comes later, as it grows);
  /// throws kfx::Error naming the sizes when the GPU lacks the memory. No-op once done.
  void reserve(int res, cudaStream_t stream);
  /// Meshes `volume` in stream order after what `stream` already holds and waits for the
  /// result: a view of pinned host memory valid until the next call or the extractor's end.
  /// `debug_sync` synchronises after every launch (KFX_CUDA_SYNC=1).
  MeshView extract(const VolumeView& volume, cudaStream_t stream, bool debug_sync);

 private:
  int res_ = 0;
  size_t scan_bytes_ = 0;
  DeviceBuffer<uint8_t> brick_signs_;       ///< mc_brick_sign_bits per brick
  DeviceBuffer<uint8_t> brick_active_;      ///< mc_brick_active per brick
  DeviceBuffer<uint8_t> vertex_count_;      ///< a byte per voxel, by run
  DeviceBuffer<uint32_t> run_offset_;       ///< mc_run_count() + 1
  DeviceBuffer<uint32_t> triangle_count_;   ///< kMcZChunks·res² + 1 per-segment counts
  DeviceBuffer<uint32_t> triangle_offset_;  ///< their exclusive sum
  DeviceBuffer<uint8_t> scan_temp_;
  DeviceBuffer<McTable> table_;
  PinnedBuffer<uint32_t> totals_;      ///< vertices, triangles
  DeviceBuffer<MeshVertex> vertices_;  ///< grow to the largest mesh so far (with slack)
  DeviceBuffer<MeshTriangle> triangles_;
  PinnedBuffer<MeshVertex> host_vertices_;  ///< what extract() returns
  PinnedBuffer<MeshTriangle> host_triangles_;
};

}  // namespace kfx::cuda
