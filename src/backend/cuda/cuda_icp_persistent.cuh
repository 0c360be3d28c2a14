#pragma once
/// Persistent ICP (setting cuda_icp_persistent): all iterations of one pyramid level in ONE
/// cooperative launch instead of one launch per iteration. Each iteration, every block tracks
/// and sums exactly the pixels a block of icp_iteration_kernel would (track_block_partial with
/// the same block index and grid width), the grid meets at one barrier (grid_barrier), and then
/// EVERY block adds the partials in the same fixed order (sum_partials_in_order) and runs the
/// same single-thread solve on its own shared-memory copy of the state. Same inputs, same code,
/// so every block reaches the same bits, the same pose and the same convergence decision without
/// a second barrier (the design note in ../shared/DESIGN.md measured barriers as the cost), and
/// the results are bit-identical to the launch-per-iteration path.

#include <algorithm>
#include <string>

#include "backend/cuda/cuda_check.hpp"
#include "backend/cuda/cuda_kernels.cuh"

namespace kfx::cuda {

/// Grid-wide barrier on a counter of block arrivals that only grows: each block adds its arrival
/// without waiting for the old value (cooperative_groups' grid.sync waits for it before it
/// starts polling: a round trip to L2 more; bench/RESULTS.md, "Figures moved out of code
/// comments") and
/// polls until the counter reaches `target`. Release/acquire at device scope: what a block wrote
/// before the barrier is visible to every block after it. The signed difference keeps the test
/// right when the counter wraps.
__device__ inline void grid_barrier(unsigned int* arrivals, unsigned int target) {
  __syncthreads();
  if (threadIdx.x == 0) {
    asm volatile("red.release.gpu.global.add.u32 [%0], 1;" ::"l"(arrivals) : "memory");
    unsigned int seen;
    do {
      asm volatile("ld.acquire.gpu.global.u32 %0, [%1];" : "=r"(seen) : "l"(arrivals) : "memory");
    } while (static_cast<int>(seen - target) < 0);
  }
  __syncthreads();
}

/// Runs up to `iterations` ICP iterations of `level` (stopping once converged) as the grid of
/// `blocks` reduction blocks that icp_iteration_kernel would use. The launch may have fewer
/// physical blocks than `blocks` (all must be co-resident: a cooperative launch); each then
/// handles the reduction blocks blockIdx.x, blockIdx.x + gridDim.x, ... one after the other, so
/// the sums are the same.
/// `partials` holds 2 × blocks accumulators: iterations alternate halves, so a block may write
/// the next iteration's partials while a slower block still reads this one's.
/// `barrier` holds two counters, zero before the first launch: [0] the grid barrier's arrivals,
/// [1] the arrivals before this launch (block 0 moves it on at the end, when every block has
/// read it: all have arrived at the last barrier by then).
/// `args.state` is ignored: the kernel tracks against its shared-memory copy of `*state`, and
/// block 0 writes that copy back at the end.
template <bool kWithPhotometric>
__global__ void __launch_bounds__(kReduceBlock)
    icp_level_kernel(TrackArgs args, TrackingState* state, double* partials, unsigned int* barrier,
                     int level, int iterations, int blocks) {
  wait_for_previous_kernel();
  // The state in shared memory: every block keeps its own copy and updates it identically.
  __shared__ TrackingState s;
  __shared__ double total[kAccumulatorSize];
  using Word = unsigned long long;
  static_assert(sizeof(TrackingState) % sizeof(Word) == 0, "TrackingState copied as 8-byte words");
  constexpr int kWords = sizeof(TrackingState) / sizeof(Word);
  for (int i = threadIdx.x; i < kWords; i += kReduceBlock) {
    reinterpret_cast<Word*>(&s)[i] = __ldcg(reinterpret_cast<const Word*>(state) + i);
  }
  const unsigned int arrivals_before = __ldcg(&barrier[1]);
  int executed = 0;
  __syncthreads();
  if (level_converged(s, level)) return;  // uniform: every block read the same state
  TrackArgs a = args;
  a.state = &s;
  for (int iteration = 0; iteration < iterations; ++iteration) {
    double* part = partials + (iteration % 2) * blocks * kAccumulatorSize;
    for (int b = blockIdx.x; b < blocks; b += gridDim.x) {
      const double block_total = track_block_partial<kWithPhotometric>(a, b, blocks);
      if (threadIdx.x < kAccumulatorSize) part[b * kAccumulatorSize + threadIdx.x] = block_total;
      __syncthreads();  // block_sum_accumulator's shared sums are reused by the next block
    }
    // The one grid-wide barrier of the iteration: every partial is written (the reads below go
    // through L2 besides).
    ++executed;
    grid_barrier(&barrier[0], arrivals_before + static_cast<unsigned int>(executed) * gridDim.x);
    sum_partials_in_order(part, blocks, total);
    if (threadIdx.x == 0) icp_update(s, total, a.icp_threshold, level);
    __syncthreads();
    // Uniform across the grid: every block computed the same update from the same sums.
    if (level_converged(s, level)) break;
  }
  if (blockIdx.x == 0) {
    for (int i = threadIdx.x; i < kWords; i += kReduceBlock) {
      reinterpret_cast<Word*>(state)[i] = reinterpret_cast<const Word*>(&s)[i];
    }
    if (threadIdx.x == 0) {
      barrier[1] = arrivals_before + static_cast<unsigned int>(executed) * gridDim.x;
    }
  }
}

/// How many blocks of icp_level_kernel this device can keep resident at once (the most a
/// cooperative launch may have); 0 with `why_not` set when it cannot launch it at all.
inline int persistent_icp_max_blocks(int device, std::string* why_not) {
  int cooperative = 0;
  KFX_CUDA_CHECK(cudaDeviceGetAttribute(&cooperative, cudaDevAttrCooperativeLaunch, device));
  if (!cooperative) {
    *why_not = "this device does not support cooperative launches";
    return 0;
  }
  // The smaller of the two instantiations' residency, so the grid fits whichever runs.
  int per_sm = 0, per_sm_photometric = 0, sms = 0;
  KFX_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, icp_level_kernel<false>,
                                                               kReduceBlock, 0));
  KFX_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(
      &per_sm_photometric, icp_level_kernel<true>, kReduceBlock, 0));
  per_sm = std::min(per_sm, per_sm_photometric);
  KFX_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
  if (per_sm < 1) {
    *why_not = "no block of the persistent ICP kernel fits on a multiprocessor";
    return 0;
  }
  return per_sm * sms;
}

/// Blocks the persistent ICP launch uses on a GPU of `sms` multiprocessors shared by `pipelines`
/// pipelines at once: all of them for one or two pipelines, about 2·sms / pipelines for more,
/// at least sms / 6. Alone, a block per multiprocessor is fastest; with many pipelines, each
/// level's launch on every multiprocessor makes the others' kernels wait for its blocks
/// (bench/RESULTS.md, "Issue 8 at `1f9b586`", persistent ICP blocks against pipelines). The
/// sums do not depend on it: each block runs its share of the same
/// reduction blocks.
inline int persistent_icp_grid(int sms, int pipelines) {
  const int share = (2 * sms + pipelines - 1) / std::max(1, pipelines);
  return std::max(1, std::max(sms / 6, std::min(sms, share)));
}

/// Launches icp_level_kernel cooperatively on `stream` with min(blocks, max_blocks) blocks
/// (max_blocks from persistent_icp_max_blocks). Capturable in a CUDA graph (a cooperative
/// kernel node). No programmatic dependent launch: the kernel starts after its predecessor.
inline void launch_icp_level(cudaStream_t stream, int max_blocks, const TrackArgs& args,
                             TrackingState* state, double* partials, unsigned int* barrier,
                             int level, int iterations, int blocks) {
  cudaLaunchConfig_t config{};
  config.gridDim = dim3(static_cast<unsigned>(std::min(blocks, max_blocks)));
  config.blockDim = dim3(kReduceBlock);
  config.stream = stream;
  cudaLaunchAttribute attribute{};
  attribute.id = cudaLaunchAttributeCooperative;
  attribute.val.cooperative = 1;
  config.attrs = &attribute;
  config.numAttrs = 1;
  const bool photometric = args.photometric.weight > 0.0f;
  KFX_CUDA_CHECK(cudaLaunchKernelEx(&config,
                                    photometric ? icp_level_kernel<true> : icp_level_kernel<false>,
                                    args, state, partials, barrier, level, iterations, blocks));
}

}  // namespace kfx::cuda
