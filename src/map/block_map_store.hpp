#pragma once
/// The block map's storage, written once for host and device memory (`Memory`:
/// map/map_memory.hpp), and the one way a new block enters it. HostBlockMap (CPU, files) and
/// the CUDA backend's DeviceBlockMap both own a BlockMapStore; each adds only what its side
/// decides differently: the host allocates a sorted candidate list in one thread, the device
/// ranks a frame's new keys in parallel (backend/cuda/cuda_block_map.cuh). Both enter a block
/// with insert_block_index, so the two maps hold the same index for the same blocks.

#include <cstdint>

#include "map/block_map.hpp"
#include "map/map_memory.hpp"

namespace kfx {

/// Adds 1 to the counter `*count` and returns its old value: atomically on the device (threads
/// enter blocks concurrently), plainly on the host (one thread enters them).
KFX_HD inline int claim_index(int* count) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(count, 1);
#else
  return (*count)++;
#endif
}

/// Key of the coarse cell holding block (bx, by, bz).
KFX_HD inline uint64_t coarse_key_of_block(const Vec3i& c) {
  return pack_block_key(c.x >> kCoarseShift, c.y >> kCoarseShift, c.z >> kCoarseShift);
}

/// Enters block `key`, absent from `map`, as block index b: its hash entry, its key, an
/// untouched flag, its direct-mapped table entry where the map keeps a table, and its coarse
/// cell when that is new (the next index of `*coarse_count`, its flag clear). On the device,
/// distinct keys may be entered concurrently; the block's coarse index (block_coarse) is then
/// known only once every thread is done: link_block_to_coarse sets it. Returns the block
/// hash's answer (kInserted unless the key was there or the hash is full).
KFX_HD inline BlockInsert insert_block_index(const BlockMapView& map, uint64_t key, int32_t b,
                                             int* coarse_count) {
  const BlockInsert outcome = map.hash.insert(key, b);
  map.block_keys[b] = key;
  map.block_touched[b] = 0;
  const Vec3i c = unpack_block_key(key);
  if (map.table.entries) map.table.insert(c.x, c.y, c.z, b);
  const uint64_t coarse = coarse_key_of_block(c);
  uint32_t slot = 0;
  if (map.coarse_hash.find(coarse) < 0 &&
      map.coarse_hash.insert(coarse, -1, &slot) == BlockInsert::kInserted) {
    const int cell = claim_index(coarse_count);
    map.coarse_touched[cell] = 0;
    map.coarse_hash.values[slot] = cell;
    if (map.coarse_table.entries) {
      map.coarse_table.insert(c.x >> kCoarseShift, c.y >> kCoarseShift, c.z >> kCoarseShift, cell);
    }
  }
  return outcome;
}

/// Sets block b's coarse index (block_coarse) from the coarse hash (after insert_block_index).
KFX_HD inline void link_block_to_coarse(const BlockMapView& map, int32_t b) {
  map.block_coarse[b] = map.coarse_hash.find(coarse_key_of_block(map.block_coords(b)));
}

/// Every array of a block map of fixed capacity, in `Memory`'s location. The counts (blocks,
/// coarse cells) are the owner's: the host keeps them on the host, the device in device memory.
template <class Memory>
struct BlockMapStore {
  template <class T>
  using Buffer = typename Memory::template Buffer<T>;

  BlockMapStore() = default;
  /// Room for `block_capacity` blocks of voxel size grid_size_m / grid_res; with `colour` a
  /// colour per voxel, with `tables` the direct-mapped tables in front of both hashes
  /// (map/block_table.hpp). Call clear() before use.
  BlockMapStore(uint32_t block_capacity, int grid_res, float grid_size_m, bool colour, bool tables)
      : hash_keys(block_hash_slot_count(block_capacity)),
        hash_values(hash_keys.size()),
        voxels(static_cast<size_t>(block_capacity) * kBlockVoxels),
        colours(colour ? static_cast<size_t>(block_capacity) * kBlockVoxels : 0),
        block_keys(block_capacity),
        block_touched(block_capacity),
        block_coarse(block_capacity),
        coarse_keys(block_hash_slot_count(block_capacity)),
        coarse_values(coarse_keys.size()),
        coarse_touched(block_capacity),
        table(tables ? static_cast<size_t>(kBlockTableEntries) : 0),
        coarse_table(tables ? static_cast<size_t>(kBlockTableEntries) : 0),
        capacity(block_capacity),
        grid_res(grid_res),
        grid_size_m(grid_size_m) {}

  /// No block (the voxels are left as they are: a block's are written when it is entered).
  void clear(const Memory& memory) const {
    // Every byte 0xff: kEmptyBlockKey, index −1, an empty table entry.
    memory.fill_bytes(hash_keys, 0xff);
    memory.fill_bytes(hash_values, 0xff);
    memory.fill_bytes(coarse_keys, 0xff);
    memory.fill_bytes(coarse_values, 0xff);
    memory.fill_bytes(block_keys, 0xff);
    memory.fill_bytes(block_coarse, 0xff);
    memory.fill_bytes(table, 0xff);
    memory.fill_bytes(coarse_table, 0xff);
    memory.fill_bytes(block_touched, 0);
    memory.fill_bytes(coarse_touched, 0);
  }
  /// Both direct-mapped tables empty (an index rebuilt from the hashes fills them again).
  void empty_tables(const Memory& memory) const {
    memory.fill_bytes(table, 0xff);
    memory.fill_bytes(coarse_table, 0xff);
  }

  /// The map as the kernels see it, with `block_count` blocks allocated.
  BlockMapView view(int block_count) const {
    BlockMapView v;
    v.hash = BlockHashView{hash_keys.data(), hash_values.data(),
                           static_cast<uint32_t>(hash_keys.size() - 1)};
    v.voxels = voxels.data();
    v.block_keys = block_keys.data();
    v.block_touched = block_touched.data();
    v.coarse_hash = BlockHashView{coarse_keys.data(), coarse_values.data(),
                                  static_cast<uint32_t>(coarse_keys.size() - 1)};
    v.coarse_touched = coarse_touched.data();
    v.block_coarse = block_coarse.data();
    v.table = BlockTableView{table.size() > 0 ? table.data() : nullptr};
    v.coarse_table = BlockTableView{coarse_table.size() > 0 ? coarse_table.data() : nullptr};
    v.block_capacity = static_cast<int>(capacity);
    v.block_count = block_count;
    v.grid_res = grid_res;
    v.grid_size_m = grid_size_m;
    v.colours = colours.size() > 0 ? colours.data() : nullptr;
    return v;
  }

  bool has_colour() const { return colours.size() > 0; }
  /// Bytes the arrays hold for the whole capacity.
  uint64_t reserved_bytes() const {
    return hash_keys.bytes() + hash_values.bytes() + voxels.bytes() + colours.bytes() +
           block_keys.bytes() + block_touched.bytes() + block_coarse.bytes() + coarse_keys.bytes() +
           coarse_values.bytes() + coarse_touched.bytes() + table.bytes() + coarse_table.bytes();
  }

  Buffer<uint64_t> hash_keys;  ///< the block hash (packed key → block index)
  Buffer<int32_t> hash_values;
  Buffer<Voxel> voxels;           ///< block i's at [i·kBlockVoxels, (i+1)·kBlockVoxels)
  Buffer<ColourVoxel> colours;    ///< laid out as the voxels; empty without colour
  Buffer<uint64_t> block_keys;    ///< packed key of block i
  Buffer<uint8_t> block_touched;  ///< BlockMapView::block_touched
  Buffer<int32_t> block_coarse;   ///< coarse index of block i
  Buffer<uint64_t> coarse_keys;   ///< the coarse hash (coarse cell key → coarse index)
  Buffer<int32_t> coarse_values;
  Buffer<uint8_t> coarse_touched;        ///< one flag per coarse cell (at most one per block)
  Buffer<BlockTableEntry> table;         ///< empty without tables
  Buffer<BlockTableEntry> coarse_table;  ///< empty without tables
  uint32_t capacity = 0;
  int grid_res = 1;
  float grid_size_m = 0.01f;
};

}  // namespace kfx
