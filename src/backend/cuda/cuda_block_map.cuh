#pragma once
/// The block map (volume=blocks) on the device: its storage, sized once from the memory budget,
/// and the thin kernels of its frame stages. Counts stay in device memory, so a frame remains a
/// fixed sequence of launches (one CUDA graph): kernels read the counts and grid-stride over
/// them, and nothing is read back on the host inside a frame.
///
/// Allocation gives the CPU's blocks and indices (HostBlockMap::allocate): the candidate keys of
/// the frame's band (band_blocks_of_pixel, the CPU's body) that the map lacks go through a
/// per-frame key set, so each distinct key is listed once whatever the thread schedule; each
/// listed key's rank among them (its place in increasing key order) makes its block index
/// block_count + rank, exactly the CPU's order; keys ranked beyond the capacity are dropped and
/// counted. Only the slots a key lands in depend on the schedule, never a lookup's answer.
/// Coarse cells (the raycast's 4³-block flags) get their indices in arrival order: they address
/// flags only, so nothing a run outputs depends on them.

#include <cuda_runtime.h>

#include <algorithm>
#include <vector>

#include "backend/cuda/cuda_kernels.cuh"
#include "backend/cuda/cuda_map_memory.cuh"
#include "backend/cuda/cuda_memory.hpp"
#include "kernels/block_allocation.hpp"
#include "kernels/integrate.hpp"
#include "kernels/ray_range.hpp"
#include "map/block_map_store.hpp"
#include "map/host_block_map.hpp"

namespace kfx::cuda {

/// The device map's counters (device memory; the frame never reads them on the host).
struct BlockMapCounts {
  int blocks;    ///< blocks allocated
  int coarse;    ///< coarse cells in use
  int new_keys;  ///< distinct keys this frame's band reached that the map lacked, all of them
  int listed;    ///< of those, the ones in the new-key list (at most its capacity)
  int visible;   ///< blocks in this frame's view
};

/// What the block-map kernels read and write.
struct DeviceBlockMapArgs {
  BlockMapView map;  ///< device arrays; its block_count is unused (counts->blocks is the count)
  BlockMapCounts* counts;
  BlockHashView frame_keys;  ///< this frame's new keys as a set (emptied after each frame)
  uint64_t* new_keys;        ///< the same keys as a list, in arrival order
  uint32_t* new_key_slots;   ///< each listed key's slot in frame_keys
  int new_key_capacity;      ///< entries of the list
  int32_t* visible_blocks;   ///< block indices in this frame's view (block_capacity entries)
};

/// Keys one frame may add on the device: 4 per compute pixel (at least 65,536). A frame's band
/// reaches far fewer distinct blocks unless voxels are tiny against the depth (a block narrower
/// than a pixel); a frame beyond it is reported (map_new_blocks_overflow), never cut silently.
inline int new_key_capacity_for(int compute_pixels) { return std::max(65536, 4 * compute_pixels); }

/// Threads per block of the grid-stride block-map kernels, and their grid (per SM).
constexpr int kMapThreads = 256;
constexpr int kMapBlocksPerSm = 8;

/// Start of a frame's allocation: the integration gate (prepare_integration, as integrate()
/// does again) and the frame's counts at zero.
__global__ void begin_block_allocation_kernel(TrackingState* state, bool always,
                                              BlockMapCounts* counts) {
  wait_for_previous_kernel();
  prepare_integration(*state, always);
  state->map_blocks_dropped = 0;
  state->map_new_blocks_overflow = 0;
  counts->new_keys = 0;
  counts->listed = 0;
  counts->visible = 0;
}

/// One thread per compute pixel: the blocks its truncation band reaches that the map lacks go
/// into the frame's key set, and the thread that adds a key lists it.
__global__ void gather_new_blocks_kernel(BlockAllocArgs alloc, DeviceBlockMapArgs m) {
  wait_for_previous_kernel();
  if (!alloc.state->integrate_now) return;
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= alloc.depth_m.width || y >= alloc.depth_m.height) return;
  uint64_t last = kEmptyBlockKey;
  band_blocks_of_pixel(x, y, alloc, [&](uint64_t key) {
    if (key == last) return;
    last = key;
    if (alloc.map.hash.find(key) >= 0 || m.frame_keys.find(key) >= 0) return;
    // Once the list is full the frame has overflowed: stop adding, so the set (twice the list's
    // slots) never fills up, which would make every lookup probe the whole table. Each thread
    // adds at most one key after the count reached the capacity (read through L2: __ldcg).
    if (__ldcg(&m.counts->new_keys) > m.new_key_capacity) return;
    uint32_t slot = 0;
    const BlockInsert outcome = m.frame_keys.insert(key, 0, &slot);
    if (outcome == BlockInsert::kPresent) return;
    // kFull cannot happen below the list's capacity (the set has twice its slots): counted, so
    // the frame reports an overflow.
    const int i = atomicAdd(&m.counts->new_keys, 1);
    if (outcome == BlockInsert::kInserted && i < m.new_key_capacity) {
      m.new_keys[i] = key;
      m.new_key_slots[i] = slot;
      atomicAdd(&m.counts->listed, 1);
    }
  });
}

/// Enters blocks 0 .. block_count − 1 and every coarse cell of the coarse hash into the
/// (emptied) direct-mapped tables, after an upload.
__global__ void fill_block_tables_kernel(BlockMapView map, int block_count) {
  const int stride = gridDim.x * blockDim.x;
  const int thread = blockIdx.x * blockDim.x + threadIdx.x;
  for (int b = thread; b < block_count; b += stride) {
    const Vec3i c = unpack_block_key(map.block_keys[b]);
    map.table.insert(c.x, c.y, c.z, b);
  }
  for (uint32_t s = thread; s <= map.coarse_hash.slot_mask; s += stride) {
    const uint64_t key = map.coarse_hash.keys[s];
    if (key == kEmptyBlockKey) continue;
    const Vec3i c = unpack_block_key(key);
    map.coarse_table.insert(c.x, c.y, c.z, map.coarse_hash.values[s]);
  }
}

/// Each listed key's rank among the listed keys (how many are smaller) is its place in
/// increasing key order: it becomes block block_count + rank while that is below the capacity
/// (HostBlockMap::allocate's order). The ranks come from tiles of the list in shared memory.
/// Also empties the frame's key set for the next frame (nothing reads it after the gather).
__global__ void __launch_bounds__(kMapThreads) allocate_new_blocks_kernel(DeviceBlockMapArgs m) {
  wait_for_previous_kernel();
  const int listed = m.counts->listed;
  const int blocks = m.counts->blocks;
  const int room = m.map.block_capacity - blocks;
  const int stride = gridDim.x * kMapThreads;
  const int thread = blockIdx.x * kMapThreads + threadIdx.x;
  if (m.counts->new_keys > m.new_key_capacity) {  // unlisted keys in the set: empty every slot
    for (uint32_t s = thread; s <= m.frame_keys.slot_mask; s += stride) {
      m.frame_keys.keys[s] = kEmptyBlockKey;
    }
  } else {
    for (int i = thread; i < listed; i += stride) {
      m.frame_keys.keys[m.new_key_slots[i]] = kEmptyBlockKey;
    }
  }
  __shared__ uint64_t tile[kMapThreads];
  for (int base = blockIdx.x * kMapThreads; base < listed; base += stride) {
    const int i = base + threadIdx.x;
    const uint64_t key = i < listed ? m.new_keys[i] : kEmptyBlockKey;
    int rank = 0;
    for (int t = 0; t < listed; t += kMapThreads) {
      __syncthreads();
      tile[threadIdx.x] = t + threadIdx.x < listed ? m.new_keys[t + threadIdx.x] : kEmptyBlockKey;
      __syncthreads();
      const int n = min(kMapThreads, listed - t);
      for (int k = 0; k < n; ++k) rank += tile[k] < key ? 1 : 0;
    }
    if (i < listed && rank < room) insert_block_index(m.map, key, blocks + rank, &m.counts->coarse);
  }
}

/// Blocks this frame adds: the listed keys while the capacity lasts.
__device__ inline int blocks_added(const DeviceBlockMapArgs& m) {
  return max(0, min(m.counts->listed, m.map.block_capacity - m.counts->blocks));
}

/// The new blocks' voxels (empty), colours (none) and coarse indices (their cells were all
/// stored by the launch before).
__global__ void init_new_blocks_kernel(DeviceBlockMapArgs m) {
  wait_for_previous_kernel();
  const int first = m.counts->blocks;
  const long long voxels = static_cast<long long>(blocks_added(m)) * kBlockVoxels;
  for (long long v = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; v < voxels;
       v += static_cast<long long>(gridDim.x) * blockDim.x) {
    const int32_t b = first + static_cast<int32_t>(v / kBlockVoxels);
    m.map.voxels[static_cast<long long>(first) * kBlockVoxels + v] = empty_voxel();
    if (m.map.colours)
      m.map.colours[static_cast<long long>(first) * kBlockVoxels + v] = {0, 0, 0, 0};
    if (v % kBlockVoxels == 0) link_block_to_coarse(m.map, b);
  }
}

/// End of a frame's allocation (one thread): the new count, and the frame's report in the state
/// (blocks, dropped, overflow), as HostBlockMap::allocate reports it on the CPU.
__global__ void finish_block_allocation_kernel(TrackingState* state, DeviceBlockMapArgs m) {
  wait_for_previous_kernel();
  const int added = blocks_added(m);
  m.counts->blocks += added;
  state->map_blocks = m.counts->blocks;
  state->map_blocks_dropped = m.counts->new_keys - added;
  state->map_new_blocks_overflow = m.counts->new_keys > m.new_key_capacity ? 1 : 0;
}

/// Lists the allocated blocks integration may change (block_in_view), in any order: each
/// block is then integrated by its own threads alone, so the order changes no result.
__global__ void find_visible_blocks_kernel(DeviceBlockMapArgs m, IntegrateArgsT<OneBlockView> a) {
  wait_for_previous_kernel();
  if (!a.state->integrate_now) return;
  const int blocks = m.counts->blocks;
  for (int b = blockIdx.x * blockDim.x + threadIdx.x; b < blocks; b += gridDim.x * blockDim.x) {
    if (block_in_view(m.map, b, a)) m.visible_blocks[atomicAdd(&m.counts->visible, 1)] = b;
  }
}

/// Integration over the visible blocks: 64 threads per block, one x-row each (integrate_block's
/// rows, integrate_row_range over the block's 8 voxels), blockDim.y blocks per thread block.
__global__ void integrate_blocks_kernel(DeviceBlockMapArgs m, IntegrateArgsT<OneBlockView> a) {
  wait_for_previous_kernel();
  if (!a.state->integrate_now) return;
  const int visible = m.counts->visible;
  const int row = threadIdx.x;  // 0 .. kBlockSide² − 1
  for (int v = blockIdx.x * blockDim.y + threadIdx.y; v < visible; v += gridDim.x * blockDim.y) {
    a.volume = one_block_view(m.map, m.visible_blocks[v]);
    const Vec3i o = a.volume.origin_vox;
    integrate_row_range(o.y + row % kBlockSide, o.z + row / kBlockSide, o.x, o.x + kBlockSide, a);
  }
}

/// Empties the raycast's per-tile depth ranges (kernels/ray_range.hpp).
__global__ void clear_ray_ranges_kernel(RayRangeTiles tiles) {
  wait_for_previous_kernel();
  const int n = tiles.tiles_x * tiles.tiles_y;
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < n; i += gridDim.x * blockDim.x) {
    tiles.near_bits[i] = kRayRangeEmptyNear;
    tiles.far_bits[i] = kRayRangeEmptyFar;
  }
}

/// Widens the tiles' depth ranges by every touched block seen from the raycast's pose: the
/// smallest near and largest far per tile through atomics, so the order changes nothing.
__global__ void ray_ranges_of_blocks_kernel(DeviceBlockMapArgs m, RayRangeArgs r,
                                            const TrackingState* state) {
  wait_for_previous_kernel();
  const Mat4f T_cam_world = rigid_inverse(state->T_world_raycast);
  const int blocks = m.counts->blocks;
  for (int b = blockIdx.x * blockDim.x + threadIdx.x; b < blocks; b += gridDim.x * blockDim.x) {
    widen_ray_ranges(m.map, b, T_cam_world, r, [&](int i, uint32_t near_bits, uint32_t far_bits) {
      atomicMin(r.tiles.near_bits + i, near_bits);
      atomicMax(r.tiles.far_bits + i, far_bits);
    });
  }
}

/// The device block map: the shared storage (BlockMapStore, with the direct-mapped tables),
/// its counts in device memory, and the per-frame allocation buffers; every array allocated
/// once, for `block_capacity` blocks.
class DeviceBlockMap {
 public:
  DeviceBlockMap() = default;
  /// With `colour`, each block carries kBlockVoxels colours beside its voxels.
  DeviceBlockMap(uint32_t block_capacity, int grid_res, float grid_size_m, bool colour,
                 int new_key_capacity)
      : store_(block_capacity, grid_res, grid_size_m, colour, /*tables=*/true),
        counts_(1),
        frame_keys_(block_hash_slot_count(static_cast<uint32_t>(new_key_capacity))),
        frame_values_(frame_keys_.size()),
        new_keys_(static_cast<size_t>(new_key_capacity)),
        new_key_slots_(static_cast<size_t>(new_key_capacity)),
        visible_(block_capacity),
        new_key_capacity_(new_key_capacity) {}

  /// Empties the map (in stream order): every hash slot free, every count 0.
  void clear(const DeviceMemory& memory) {
    store_.clear(memory);
    memory.fill_bytes(frame_keys_, 0xff);    // kEmptyBlockKey
    memory.fill_bytes(frame_values_, 0xff);  // −1
    memory.fill_bytes(counts_, 0);
  }

  /// The map as the kernels see it.
  DeviceBlockMapArgs args() const {
    DeviceBlockMapArgs a;
    a.map = view();
    a.counts = counts_.data();
    a.frame_keys = BlockHashView{frame_keys_.data(), frame_values_.data(),
                                 static_cast<uint32_t>(frame_keys_.size() - 1)};
    a.new_keys = new_keys_.data();
    a.new_key_slots = new_key_slots_.data();
    a.new_key_capacity = new_key_capacity_;
    a.visible_blocks = visible_.data();
    return a;
  }
  /// Its block_count is 0: on the device only counts->blocks holds the count.
  BlockMapView view() const { return store_.view(0); }

  /// A host copy of the blocks in increasing key order (HostBlockMap::contents_into's form). Waits
  /// for `stream`.
  BlockMapContents download(cudaStream_t stream) const {
    BlockMapContents c;
    download_into(c, stream);
    return c;
  }

  /// The same into `c`, reusing its arrays' memory (the swap passes download the map again and
  /// again). The blocks come down in the device's order and are sorted in place, so the host
  /// holds one copy of the map, not two.
  void download_into(BlockMapContents& c, cudaStream_t stream) const {
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream));
    BlockMapCounts counts{};
    KFX_CUDA_CHECK(cudaMemcpy(&counts, counts_.data(), sizeof(counts), cudaMemcpyDeviceToHost));
    const size_t n = static_cast<size_t>(counts.blocks);
    c.grid_res = store_.grid_res;
    c.grid_size_m = store_.grid_size_m;
    c.keys.resize(n);
    c.voxels.resize(n * kBlockVoxels);
    c.colours.resize(store_.has_colour() ? n * kBlockVoxels : 0);
    copy_down(c.keys.data(), store_.block_keys.data(), n);
    copy_down(c.voxels.data(), store_.voxels.data(), c.voxels.size());
    copy_down(c.colours.data(), store_.colours.data(), c.colours.size());
    sort_blocks_by_key(c);
  }

  /// Replaces the map by `contents` (HostBlockMap::load's checks and layout: every block
  /// touched), copied whole to the device. Returns the block count. Waits for `stream`.
  int upload(const BlockMapContents& contents, cudaStream_t stream) {
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream));
    // The index is built on the host; the voxels go up from `contents` itself (block i at
    // index i), so the host holds no second copy of the map.
    HostBlockMap host(store_.capacity, store_.grid_res, store_.grid_size_m, store_.has_colour());
    host.load_index(contents);
    const BlockMapStore<HostMemory>& h = host.store();
    const size_t n = static_cast<size_t>(host.block_count());
    copy_up(store_.hash_keys.data(), h.hash_keys.data(), store_.hash_keys.size());
    copy_up(store_.hash_values.data(), h.hash_values.data(), store_.hash_values.size());
    copy_up(store_.coarse_keys.data(), h.coarse_keys.data(), store_.coarse_keys.size());
    copy_up(store_.coarse_values.data(), h.coarse_values.data(), store_.coarse_values.size());
    copy_up(store_.block_keys.data(), h.block_keys.data(), n);
    copy_up(store_.block_touched.data(), h.block_touched.data(), n);
    copy_up(store_.block_coarse.data(), h.block_coarse.data(), n);
    copy_up(store_.coarse_touched.data(), h.coarse_touched.data(),
            static_cast<size_t>(host.coarse_count()));
    copy_up(store_.voxels.data(), contents.voxels.data(), n * kBlockVoxels);
    if (store_.has_colour() && !contents.colours.empty()) {
      copy_up(store_.colours.data(), contents.colours.data(), n * kBlockVoxels);
    } else if (store_.has_colour() && n > 0) {  // colours the contents lack read as none yet
      KFX_CUDA_CHECK(cudaMemset(store_.colours.data(), 0, n * kBlockVoxels * sizeof(ColourVoxel)));
    }
    const BlockMapCounts counts{host.block_count(), host.coarse_count(), 0, 0, 0};
    copy_up(counts_.data(), &counts, 1);
    store_.empty_tables(DeviceMemory{stream});
    fill_block_tables_kernel<<<4096, kMapThreads, 0, stream>>>(view(), host.block_count());
    KFX_CUDA_CHECK(cudaGetLastError());
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream));
    return host.block_count();
  }

  uint32_t capacity() const { return store_.capacity; }

 private:
  template <class T>
  static void copy_up(T* device, const T* host, size_t count) {
    if (count == 0) return;
    KFX_CUDA_CHECK(cudaMemcpy(device, host, count * sizeof(T), cudaMemcpyHostToDevice));
  }
  template <class T>
  static void copy_down(T* host, const T* device, size_t count) {
    if (count == 0) return;
    KFX_CUDA_CHECK(cudaMemcpy(host, device, count * sizeof(T), cudaMemcpyDeviceToHost));
  }

  BlockMapStore<DeviceMemory> store_;
  DeviceBuffer<BlockMapCounts> counts_;
  DeviceBuffer<uint64_t> frame_keys_;
  DeviceBuffer<int32_t> frame_values_;
  DeviceBuffer<uint64_t> new_keys_;
  DeviceBuffer<uint32_t> new_key_slots_;
  DeviceBuffer<int32_t> visible_;
  int new_key_capacity_ = 0;
};

}  // namespace kfx::cuda
