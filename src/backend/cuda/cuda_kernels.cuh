#pragma once
/// Thin __global__ stubs: each computes its index, bounds-checks and calls the shared kernel
/// body from src/kernels/. The only GPU-specific code is the index mapping and the fixed-order
/// block reductions.

#include <cuda_runtime.h>

#include "kernels/camera_move.hpp"
#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"
#include "kernels/photometric.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/raycast.hpp"
#include "kernels/render.hpp"
#include "kernels/track.hpp"

namespace kfx::cuda {

/// Threads per block of the reduction kernels.
constexpr int kReduceBlock = 256;

/// First statement of every kernel: wait until the previous kernel in the stream has finished
/// and its writes are visible. A no-op for an ordinary launch; with programmatic dependent
/// launch (the default on Hopper) it lets a kernel be launched while its predecessor runs.
__device__ __forceinline__ void wait_for_previous_kernel() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  asm volatile("griddepcontrol.wait;" ::: "memory");
#endif
}

/// One thread per pixel of a width × height grid, calling Body{}(x, y, args).
template <class Body, class Args>
__global__ void pixel_kernel(Args args, int width, int height) {
  wait_for_previous_kernel();
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < width && y < height) Body{}(x, y, args);
}

struct BilateralBody {
  __device__ void operator()(int x, int y, const BilateralArgs& a) const {
    bilateral_pixel(x, y, a);
  }
};
struct HalfSampleBody {
  __device__ void operator()(int x, int y, const HalfSampleArgs& a) const {
    half_sample_pixel(x, y, a);
  }
};
struct DepthToVertexBody {
  __device__ void operator()(int x, int y, const DepthToVertexArgs& a) const {
    depth_to_vertex_pixel(x, y, a);
  }
};
struct VertexToNormalBody {
  __device__ void operator()(int x, int y, const VertexToNormalArgs& a) const {
    vertex_to_normal_pixel(x, y, a);
  }
};
struct IntensityBody {
  __device__ void operator()(int x, int y, const IntensityArgs& a) const {
    intensity_pixel(x, y, a);
  }
};
struct HalfIntensityBody {
  __device__ void operator()(int x, int y, const HalfIntensityArgs& a) const {
    half_intensity_pixel(x, y, a);
  }
};
struct KeepIntensityBody {
  __device__ void operator()(int x, int y, const KeepIntensityArgs& a) const {
    keep_intensity_pixel(x, y, a);
  }
};
/// `Map`: VolumeView (the dense cube) or BlockMapView; `Step`: raycast_step_of the settings.
template <class Map, RaycastStep Step = RaycastStep::kKFusion>
struct RaycastBlockBodyT {
  __device__ void operator()(int x, int y, const RaycastArgsT<Map>& a) const {
    raycast_block<Step>(x, y, a);
  }
};
using RaycastBlockBody = RaycastBlockBodyT<VolumeView>;
struct RaycastNeighbourNormalBody {
  __device__ void operator()(int x, int y, const RaycastNeighbourNormalArgs& a) const {
    raycast_neighbour_normal_pixel(x, y, a);
  }
};
struct RenderDepthBody {
  __device__ void operator()(int x, int y, const RenderDepthArgs& a) const {
    render_depth_pixel(x, y, a);
  }
};
struct RenderTrackBody {
  __device__ void operator()(int x, int y, const RenderTrackArgs& a) const {
    render_track_pixel(x, y, a);
  }
};
template <class Map>
struct RenderColourBodyT {
  __device__ void operator()(int x, int y, const RenderColourArgsT<Map>& a) const {
    render_colour_pixel(x, y, a);
  }
};
using RenderColourBody = RenderColourBodyT<VolumeView>;
template <class Map>
struct RenderVolumeBodyT {
  __device__ void operator()(int x, int y, const RenderVolumeArgsT<Map>& a) const {
    render_volume_pixel(x, y, a);
  }
};
using RenderVolumeBody = RenderVolumeBodyT<VolumeView>;

/// The largest of every thread's `value` (≥ 0) in the block; valid in thread (0, 0). A max is
/// exact whatever the order, so this stays repeatable.
__device__ inline float block_max(float value) {
  for (int offset = 16; offset > 0; offset /= 2) {
    value = fmaxf(value, __shfl_down_sync(0xffffffffu, value, offset));
  }
  __shared__ float warp_max[32];
  const int lane = (threadIdx.y * blockDim.x + threadIdx.x) % 32;
  const int warp = (threadIdx.y * blockDim.x + threadIdx.x) / 32;
  if (lane == 0) warp_max[warp] = value;
  __syncthreads();
  float m = 0.0f;
  if (warp == 0) {
    const int warps = (blockDim.x * blockDim.y + 31) / 32;
    m = lane < warps ? warp_max[lane] : 0.0f;
    for (int offset = 16; offset > 0; offset /= 2) {
      m = fmaxf(m, __shfl_down_sync(0xffffffffu, m, offset));
    }
  }
  return m;
}

/// mm → metres, and the frame's largest depth (block max, then one atomic per block into
/// state->max_depth_m, which must be 0 before the launch).
__global__ void mm_to_m_kernel(MmToMArgs args, TrackingState* state) {
  wait_for_previous_kernel();
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  float d = 0.0f;
  if (x < args.out_m.width && y < args.out_m.height) d = mm_to_m_pixel(x, y, args);
  if (x == 0 && y == 0) begin_frame_state(*state);  // once per frame, first thing
  const float m = block_max(d);
  // Non-negative floats order like their bit patterns as ints.
  if (threadIdx.x == 0 && threadIdx.y == 0) {
    atomicMax(reinterpret_cast<int*>(&state->max_depth_m), __float_as_int(m));
  }
}

/// Block shape of the fused preprocess and pyramid kernels: one tile of output pixels each.
constexpr int kTileWidthPx = 32;
constexpr int kTileHeightPx = 8;

/// The frame's largest depth without a memset per frame: every block folds its maximum into
/// scratch[0] (bit patterns: non-negative floats order like unsigned ints) and counts itself in
/// scratch[1]; the last block to finish moves the maximum into state->max_depth_m and zeroes
/// both for the next frame. `scratch` is 0, 0 before the first frame. Called by every thread.
__device__ inline void publish_max_depth(float depth_m, TrackingState* state,
                                         unsigned int* scratch) {
  const float m = block_max(depth_m);
  if (threadIdx.x != 0 || threadIdx.y != 0) return;
  atomicMax(&scratch[0], __float_as_uint(m));
  __threadfence();  // the max before the count: the last block sees every block's max
  const unsigned int blocks = gridDim.x * gridDim.y;
  if (atomicAdd(&scratch[1], 1u) == blocks - 1) {
    state->max_depth_m = __uint_as_float(atomicExch(&scratch[0], 0u));
    scratch[1] = 0;
  }
}

/// mm → metres and the bilateral filter in one launch (preprocess_pixel), with the frame's
/// largest depth. Each block converts its tile and a halo of the filter radius into shared
/// memory once (preprocess_input_m), then filters its pixels from there.
__global__ void __launch_bounds__(kTileWidthPx* kTileHeightPx)
    preprocess_kernel(PreprocessArgs args, TrackingState* state, unsigned int* max_scratch) {
  wait_for_previous_kernel();
  constexpr int kMaxSide = 2 * kMaxBilateralRadius;
  __shared__ float tile_m[kTileHeightPx + kMaxSide][kTileWidthPx + kMaxSide];
  const int r = args.radius_px;
  const int x0 = blockIdx.x * kTileWidthPx, y0 = blockIdx.y * kTileHeightPx;
  const int tile_w = kTileWidthPx + 2 * r, tile_h = kTileHeightPx + 2 * r;
  for (int t = threadIdx.y * kTileWidthPx + threadIdx.x; t < tile_w * tile_h;
       t += kTileWidthPx * kTileHeightPx) {
    const int tx = t % tile_w, ty = t / tile_w;
    tile_m[ty][tx] = preprocess_input_m(x0 + tx - r, y0 + ty - r, args);
  }
  __syncthreads();
  const int x = x0 + threadIdx.x, y = y0 + threadIdx.y;
  float d = 0.0f;
  if (x < args.mm.out_m.width && y < args.mm.out_m.height) {
    d = preprocess_pixel(
        x, y, args, [&](int i, int j) { return tile_m[threadIdx.y + r + j][threadIdx.x + r + i]; });
  }
  if (x == 0 && y == 0) begin_frame_state(*state);  // once per frame, first thing
  publish_max_depth(d, state, max_scratch);
}

/// Where the blocks of the fused pyramid launch go: level l has blocks first_block[l] up to
/// first_block[l + 1], blocks_across[l] tiles per row.
struct PyramidGrid {
  int first_block[kMaxPyramidLevels + 1] = {};
  int blocks_across[kMaxPyramidLevels] = {};
};

/// Every pyramid level in one launch: each block takes a tile of one level, computes the depth
/// and vertex of its pixels and a one-pixel halo into shared memory (pyramid_vertex), then the
/// normals of its pixels from there (pyramid_normal_pixel).
__global__ void __launch_bounds__(kTileWidthPx* kTileHeightPx)
    pyramid_kernel(PyramidArgs args, PyramidGrid grid) {
  wait_for_previous_kernel();
  int level = 0;
  while (level + 1 < args.levels && static_cast<int>(blockIdx.x) >= grid.first_block[level + 1]) {
    ++level;
  }
  const int block = blockIdx.x - grid.first_block[level];
  const int x0 = (block % grid.blocks_across[level]) * kTileWidthPx;
  const int y0 = (block / grid.blocks_across[level]) * kTileHeightPx;
  const int w = args.vertex[level].width, h = args.vertex[level].height;
  constexpr int kTileW = kTileWidthPx + 2, kTileH = kTileHeightPx + 2;
  __shared__ Vec3f tile[kTileH][kTileW];
  for (int t = threadIdx.y * kTileWidthPx + threadIdx.x; t < kTileW * kTileH;
       t += kTileWidthPx * kTileHeightPx) {
    const int tx = t % kTileW, ty = t / kTileW;
    const int x = x0 + tx - 1, y = y0 + ty - 1;
    if (x < 0 || y < 0 || x >= w || y >= h) continue;  // never read: neighbours are clamped
    const bool own = tx >= 1 && tx <= kTileWidthPx && ty >= 1 && ty <= kTileHeightPx;
    tile[ty][tx] = pyramid_vertex(level, x, y, args, own);
  }
  __syncthreads();
  const int x = x0 + threadIdx.x, y = y0 + threadIdx.y;
  if (x < w && y < h) {
    pyramid_normal_pixel(level, x, y, args,
                         [&](int u, int v) { return tile[v - y0 + 1][u - x0 + 1]; });
  }
}

__global__ void begin_tracking_kernel(TrackingState* state, IcpGuessParams params) {
  wait_for_previous_kernel();
  begin_tracking(*state, params);
}
__global__ void accept_kernel(TrackingState* state, AcceptParams params) {
  wait_for_previous_kernel();
  accept_or_revert(*state, params);
}
__global__ void skip_tracking_kernel(TrackingState* state) {
  wait_for_previous_kernel();
  state->tracked = 0;
}
__global__ void keep_intensity_pose_kernel(TrackingState* state, int always) {
  wait_for_previous_kernel();
  keep_intensity_pose(*state, always);
}
__global__ void prepare_integration_kernel(TrackingState* state, bool always) {
  wait_for_previous_kernel();
  prepare_integration(*state, always);
}
/// Moves the camera to the pose stage_pose() copied to the device (a relocalisation attempt).
__global__ void adopt_pose_kernel(TrackingState* state, const Mat4f* T_world_cam) {
  wait_for_previous_kernel();
  move_camera(*state, *T_world_cam);
}
__global__ void set_reference_kernel(TrackingState* state, Intrinsics k) {
  wait_for_previous_kernel();
  set_reference_view(*state, k);
}

/// Sums kAccumulatorSize doubles over the block in a fixed order. Thread t < kAccumulatorSize
/// returns element t of the block's total. One shuffle step folds lane l + 16 onto lane l; the 16
/// half-sums of each warp then go through shared memory, where thread (warp w, value v) adds
/// warp w's 16 in lane order; finally the 8 warps in order. A full shuffle tree needs 5 steps of
/// 32 double shuffles per warp, and shuffles are what limited this sum (ICP runs it every
/// iteration, between the track and the grid barrier).
__device__ inline double block_sum_accumulator(const double (&acc)[kAccumulatorSize]) {
  constexpr int kWarps = kReduceBlock / 32;
  constexpr int kHalfLanes = 16;
  static_assert(kAccumulatorSize == 32, "one thread per (warp, value) in the second stage");
  // Row stride 17: threads (w, 0..31) reading lane k of their rows hit different banks.
  __shared__ double half_sums[kWarps][kAccumulatorSize][kHalfLanes + 1];
  __shared__ double warp_sums[kWarps][kAccumulatorSize];
  const int lane = threadIdx.x % 32, warp = threadIdx.x / 32;
#pragma unroll
  for (int i = 0; i < kAccumulatorSize; ++i) {
    const double folded = acc[i] + __shfl_down_sync(0xffffffffu, acc[i], kHalfLanes);
    if (lane < kHalfLanes) half_sums[warp][i][lane] = folded;
  }
  __syncthreads();
  {
    const int w = threadIdx.x / kAccumulatorSize, v = threadIdx.x % kAccumulatorSize;
    double sum = 0.0;
#pragma unroll
    for (int k = 0; k < kHalfLanes; ++k) sum += half_sums[w][v][k];
    warp_sums[w][v] = sum;
  }
  __syncthreads();
  double total = 0.0;
  if (threadIdx.x < kAccumulatorSize) {
    for (int w = 0; w < kWarps; ++w) total += warp_sums[w][threadIdx.x];
  }
  return total;
}

/// Tracks the samples of reduction block `block` of a grid of `blocks` (sample i belongs to block
/// (i / kReduceBlock) % blocks, thread i % kReduceBlock) and sums them over the block with
/// block_sum_accumulator. Every sum's order depends only on (block, blocks), so any launch that
/// calls this with the same pair gets the same bits (cuda_icp_persistent relies on it).
/// kWithPhotometric: whether the photometric row is compiled in (track_sample).
template <bool kWithPhotometric>
__device__ inline double track_block_partial(const TrackArgs& args, int block, int blocks) {
  const int grid_w = track_grid_width(args);
  const int samples = grid_w * track_grid_height(args);
  double acc[kAccumulatorSize];
#pragma unroll
  for (int i = 0; i < kAccumulatorSize; ++i) acc[i] = 0.0;
  for (int i = block * kReduceBlock + threadIdx.x; i < samples; i += blocks * kReduceBlock) {
    track_sample<kWithPhotometric>(i % grid_w, i / grid_w, args, acc);
  }
  return block_sum_accumulator(acc);
}

/// The final reduction of `blocks` partial accumulators (kAccumulatorSize doubles each, block
/// after block) in a fixed order: 8 groups of 32 threads sum interleaved blocks, then the groups
/// in order. Called by all kReduceBlock threads of one block; `total` (kAccumulatorSize doubles,
/// shared memory) holds the result after it returns. Partials are read through L2 (__ldcg): other
/// blocks wrote them in this launch.
__device__ inline void sum_partials_in_order(const double* partials, int blocks, double* total) {
  __shared__ double group_sums[kReduceBlock / kAccumulatorSize][kAccumulatorSize];
  const int value = threadIdx.x % kAccumulatorSize, group = threadIdx.x / kAccumulatorSize;
  double group_sum = 0.0;
  for (int b = group; b < blocks; b += kReduceBlock / kAccumulatorSize) {
    group_sum += __ldcg(&partials[b * kAccumulatorSize + value]);
  }
  group_sums[group][value] = group_sum;
  __syncthreads();
  if (threadIdx.x < kAccumulatorSize) {
    double t = 0.0;
    for (int g = 0; g < kReduceBlock / kAccumulatorSize; ++g) t += group_sums[g][threadIdx.x];
    total[threadIdx.x] = t;
  }
  __syncthreads();
}

/// One ICP iteration in one launch: every thread tracks its pixels and accumulates; blocks
/// write partial sums; the last block to finish adds the partials in block order, solves the
/// 6×6 system and updates the pose. A no-op once the level has converged. kWithPhotometric: the
/// photometric row compiled in (runs with photometric_weight > 0).
template <bool kWithPhotometric>
__global__ void __launch_bounds__(kReduceBlock)
    icp_iteration_kernel(TrackArgs args, TrackingState* state, double* partials,
                         unsigned int* blocks_done, int level) {
  wait_for_previous_kernel();
  if (level_converged(*state, level)) return;  // uniform: set by an earlier launch
  const double block_total = track_block_partial<kWithPhotometric>(args, blockIdx.x, gridDim.x);
  __shared__ bool is_last;
  if (threadIdx.x < kAccumulatorSize) {
    partials[blockIdx.x * kAccumulatorSize + threadIdx.x] = block_total;
  }
  __threadfence();
  __syncthreads();
  if (threadIdx.x == 0) is_last = atomicAdd(blocks_done, 1u) == gridDim.x - 1;
  __syncthreads();
  if (!is_last) return;
  __shared__ double total[kAccumulatorSize];
  sum_partials_in_order(partials, gridDim.x, total);
  if (threadIdx.x == 0) {
    icp_update(*state, total, args.icp_threshold, level);
    *blocks_done = 0;  // ready for the next launch
  }
}

/// Integration: one thread per voxel column (x, y) and z-chunk; early-out unless this frame
/// integrates.
__global__ void integrate_kernel(IntegrateArgs args, int z_chunks) {
  wait_for_previous_kernel();
  if (!args.state->integrate_now) return;
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  const int res = args.volume.res;
  if (x >= res || y >= res) return;
  int z_begin, z_end;
  integrate_column_bounds(x, y, args, z_begin, z_end);
  const int chunk = (res + z_chunks - 1) / z_chunks;
  const int c = blockIdx.z;
  integrate_column(x, y, max(z_begin, c * chunk), min(z_end, (c + 1) * chunk), args);
}

}  // namespace kfx::cuda
