#include <thrust/iterator/counting_iterator.h>
#include <thrust/iterator/transform_iterator.h>

#include <algorithm>
#include <cub/device/device_scan.cuh>

#include "backend/backend.hpp"
#include "backend/cuda/cuda_mesh.hpp"

namespace kfx::cuda {
namespace {

static_assert(kBrickShift == 3, "brick_sign_kernel maps 8-voxel bricks onto 8-lane groups");

/// mc_brick_sign_bits for every brick, read coalesced: a block covers 4 bricks along x by one
/// brick row (32 × 8 threads, each ORing its voxel column over the brick's 8 z); shuffles OR the
/// 8 lanes of a brick, shared memory the 8 rows.
__global__ void brick_sign_kernel(VolumeView volume, uint8_t* signs) {
  const int res = volume.res, b = bricks_per_side(res);
  const int x = blockIdx.x * 32 + threadIdx.x, y = blockIdx.y * 8 + threadIdx.y;
  const int z0 = blockIdx.z * 8;
  unsigned bits = 0;
  if (x < res && y < res) {
#pragma unroll
    for (int k = 0; k < 8; ++k) {
      if (z0 + k < res) bits |= mc_voxel_sign_bits(volume.at(x, y, z0 + k));
    }
  }
  bits |= __shfl_xor_sync(0xffffffffu, bits, 1);
  bits |= __shfl_xor_sync(0xffffffffu, bits, 2);
  bits |= __shfl_xor_sync(0xffffffffu, bits, 4);
  __shared__ unsigned rows[8][4];
  if ((threadIdx.x & 7) == 0) rows[threadIdx.y][threadIdx.x >> 3] = bits;
  __syncthreads();
  if (threadIdx.y == 0 && threadIdx.x < 4) {
    unsigned brick = 0;
    for (int r = 0; r < 8; ++r) brick |= rows[r][threadIdx.x];
    const int bx = blockIdx.x * 4 + threadIdx.x;
    if (bx < b) {
      signs[bx + blockIdx.y * b + static_cast<long long>(blockIdx.z) * b * b] =
          static_cast<uint8_t>(brick);
    }
  }
}

/// Marching cubes: one thread per column segment (x, y, z slab = blockIdx.z); pass 1 (count)
/// or pass 2 (write).
template <bool kWrite>
__global__ void marching_cubes_kernel(MarchingCubesArgs args) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  const int res = args.volume.res;
  if (x >= res || y >= res) return;
  if (kWrite) {
    mc_write_column(x, y, blockIdx.z, args);
  } else {
    mc_count_column(x, y, blockIdx.z, args);
  }
}

/// mc_brick_active for every brick, one thread each.
__global__ void brick_active_kernel(const uint8_t* signs, uint8_t* active, int b) {
  const long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  if (i >= static_cast<long long>(b) * b * b) return;
  const int bx = static_cast<int>(i % b), by = static_cast<int>(i / b % b),
            bz = static_cast<int>(i / b / b);
  active[i] = mc_brick_active(signs, bx, by, bz, b);
}

/// The vertex scan's input: mc_run_vertex_count for run i, 0 for the one-past-last entry (so
/// its exclusive sum is the total). Read on the fly by the scan: no per-run count array.
struct RunVertexCount {
  MarchingCubesArgs args;
  long long runs;
  __host__ __device__ uint32_t operator()(long long run) const {
    return run < runs ? mc_run_vertex_count(args, run) : 0u;
  }
};

auto run_vertex_counts(const MarchingCubesArgs& args, long long runs) {
  return thrust::make_transform_iterator(thrust::counting_iterator<long long>(0),
                                         RunVertexCount{args, runs});
}

/// Capacity for `needed` elements of a growing buffer: a quarter more, so a mesh that grows a
/// little between calls does not reallocate every time.
size_t grown(size_t needed) { return needed + needed / 4 + 1024; }

}  // namespace

void MeshExtractor::reserve(int res, cudaStream_t stream) {
  if (res_ == res) return;
  const size_t r = static_cast<size_t>(res);
  const long long runs = mc_run_count(res);
  const size_t bricks = static_cast<size_t>(bricks_per_side(res));
  const size_t segments = kMcZChunks * r * r + 1;
  size_t run_scan_bytes = 0, segment_scan_bytes = 0;
  KFX_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(
      nullptr, run_scan_bytes, run_vertex_counts(MarchingCubesArgs{}, runs),
      static_cast<uint32_t*>(nullptr), static_cast<int>(runs + 1)));
  KFX_CUDA_CHECK(
      cub::DeviceScan::ExclusiveSum(nullptr, segment_scan_bytes, static_cast<uint32_t*>(nullptr),
                                    static_cast<uint32_t*>(nullptr), static_cast<int>(segments)));
  scan_bytes_ = std::max(run_scan_bytes, segment_scan_bytes);
  const size_t needed = mesh_scratch_bytes(res) + scan_bytes_;
  size_t free_bytes = 0, total_bytes = 0;
  KFX_CUDA_CHECK(cudaMemGetInfo(&free_bytes, &total_bytes));
  KFX_CHECK(needed < free_bytes, "mesh extraction of a "
                                     << r << "^3 volume needs " << needed / double(1 << 30)
                                     << " GiB of GPU memory beyond the volume, "
                                     << free_bytes / double(1 << 30)
                                     << " GiB are free (use --no-mesh or a smaller -v)");
  brick_signs_ = DeviceBuffer<uint8_t>(bricks * bricks * bricks);
  brick_active_ = DeviceBuffer<uint8_t>(bricks * bricks * bricks);
  vertex_count_ = DeviceBuffer<uint8_t>(static_cast<size_t>(runs) << kBrickShift);
  run_offset_ = DeviceBuffer<uint32_t>(static_cast<size_t>(runs) + 1);
  triangle_count_ = DeviceBuffer<uint32_t>(segments);
  triangle_offset_ = DeviceBuffer<uint32_t>(segments);
  scan_temp_ = DeviceBuffer<uint8_t>(scan_bytes_);
  table_ = DeviceBuffer<McTable>(1);
  totals_ = PinnedBuffer<uint32_t>(2);
  KFX_CUDA_CHECK(
      cudaMemcpyAsync(table_.data(), &kMcTable, sizeof(McTable), cudaMemcpyHostToDevice, stream));
  // The last segment count stays 0, so its exclusive sum is the total.
  KFX_CUDA_CHECK(cudaMemsetAsync(triangle_count_.data(), 0, triangle_count_.bytes(), stream));
  res_ = res;
}

MeshView MeshExtractor::extract(const VolumeView& volume, cudaStream_t stream, bool debug_sync) {
  reserve(volume.res, stream);
  const auto launched = [&] {
    KFX_CUDA_LAUNCH_CHECK();
    if (debug_sync) KFX_CUDA_CHECK(cudaStreamSynchronize(stream));
  };
  const int res = volume.res, b = bricks_per_side(res);
  const long long bricks = static_cast<long long>(b) * b * b;
  // Pass 0: which bricks can hold any of the mesh (one read of the volume).
  brick_sign_kernel<<<dim3((res + 31) / 32, b, b), dim3(32, 8), 0, stream>>>(volume,
                                                                             brick_signs_.data());
  launched();
  brick_active_kernel<<<static_cast<unsigned>((bricks + 255) / 256), 256, 0, stream>>>(
      brick_signs_.data(), brick_active_.data(), b);
  launched();
  // Pass 1: counts per voxel and per column segment, active bricks only.
  MarchingCubesArgs a{volume,
                      table_.data(),
                      brick_active_.data(),
                      vertex_count_.data(),
                      run_offset_.data(),
                      triangle_count_.data(),
                      nullptr,
                      nullptr};
  const dim3 block(32, 4);
  const dim3 grid((res + block.x - 1) / block.x, (res + block.y - 1) / block.y, kMcZChunks);
  marching_cubes_kernel<false><<<grid, block, 0, stream>>>(a);
  launched();
  // Compaction: exclusive sums give every run's first vertex and every segment's first
  // triangle (integer sums: deterministic). Runs of 8 voxels make the vertex scan 8× shorter
  // than one over voxels; a voxel adds the counts before it in its run (pass 2).
  const long long runs = mc_run_count(res);
  size_t scan_bytes = scan_bytes_;
  KFX_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(scan_temp_.data(), scan_bytes,
                                               run_vertex_counts(a, runs), run_offset_.data(),
                                               static_cast<int>(runs + 1), stream));
  launched();
  const int segments = static_cast<int>(triangle_count_.size());
  scan_bytes = scan_bytes_;
  KFX_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(scan_temp_.data(), scan_bytes,
                                               triangle_count_.data(), triangle_offset_.data(),
                                               segments, stream));
  launched();
  KFX_CUDA_CHECK(cudaMemcpyAsync(totals_.data(), run_offset_.data() + runs, sizeof(uint32_t),
                                 cudaMemcpyDeviceToHost, stream));
  KFX_CUDA_CHECK(cudaMemcpyAsync(totals_.data() + 1, triangle_offset_.data() + segments - 1,
                                 sizeof(uint32_t), cudaMemcpyDeviceToHost, stream));
  KFX_CUDA_CHECK(cudaStreamSynchronize(stream));
  const size_t vertex_total = totals_.data()[0], triangle_total = totals_.data()[1];
  KFX_CHECK(vertex_total <= 0x7fffffffu,
            "the mesh has " << vertex_total << " vertices, more than PLY's int indices address");
  // The outputs only grow, device and pinned host alike: no allocation once large enough.
  if (vertices_.size() < vertex_total) {
    vertices_ = DeviceBuffer<MeshVertex>(grown(vertex_total));
    host_vertices_ = PinnedBuffer<MeshVertex>(grown(vertex_total));
  }
  if (triangles_.size() < triangle_total) {
    triangles_ = DeviceBuffer<MeshTriangle>(grown(triangle_total));
    host_triangles_ = PinnedBuffer<MeshTriangle>(grown(triangle_total));
  }
  // Pass 2: vertices and triangles at their offsets, then one direct copy each to the host.
  a.triangle_offset = triangle_offset_.data();
  a.vertices = vertices_.data();
  a.triangles = triangles_.data();
  marching_cubes_kernel<true><<<grid, block, 0, stream>>>(a);
  launched();
  if (vertex_total > 0) {
    KFX_CUDA_CHECK(cudaMemcpyAsync(host_vertices_.data(), vertices_.data(),
                                   vertex_total * sizeof(MeshVertex), cudaMemcpyDeviceToHost,
                                   stream));
  }
  if (triangle_total > 0) {
    KFX_CUDA_CHECK(cudaMemcpyAsync(host_triangles_.data(), triangles_.data(),
                                   triangle_total * sizeof(MeshTriangle), cudaMemcpyDeviceToHost,
                                   stream));
  }
  KFX_CUDA_CHECK(cudaStreamSynchronize(stream));
  return MeshView{host_vertices_.data(), vertex_total, host_triangles_.data(), triangle_total};
}

}  // namespace kfx::cuda
