#pragma once
/// A block map in host memory (the CPU backend's map, and the form a map takes in a file):
/// fixed capacities chosen at construction from a memory budget, blocks allocated in a
/// deterministic order.

#include <cstdint>
#include <vector>

#include "map/block_map.hpp"
#include "map/block_map_store.hpp"

namespace kfx {

/// Bytes one block costs in a map: its voxels, its key, its touched flag, its coarse index and
/// two hash slots in each of the two tables (kept at most half full), and a coarse flag (the
/// coarse level is sized for one cell per block, its worst case). Without colour.
constexpr uint64_t kBytesPerBlock = sizeof(Voxel) * kBlockVoxels + sizeof(uint64_t) + 1 +
                                    sizeof(int32_t) + 4 * (sizeof(uint64_t) + sizeof(int32_t)) + 1;

/// Bytes one block costs, with its colour field when `colour` (setting colour).
constexpr uint64_t block_bytes(bool colour) {
  return kBytesPerBlock + (colour ? sizeof(ColourVoxel) * kBlockVoxels : 0);
}

/// Blocks a memory budget of `budget_bytes` holds (at least 1), with colour when `colour`.
uint32_t block_capacity_for_budget(uint64_t budget_bytes, bool colour = false);

/// What one allocation pass did.
struct BlockAllocation {
  int allocated = 0;  ///< new blocks stored
  int dropped = 0;    ///< new blocks not stored: the map was at its capacity
};

/// A block map's contents in increasing key order (what a map file holds): the voxel size as
/// grid_size_m / grid_res, and per block its packed key and kBlockVoxels voxels.
struct BlockMapContents {
  int grid_res = 1;
  float grid_size_m = 0.01f;
  std::vector<uint64_t> keys;
  std::vector<Voxel> voxels;  ///< kBlockVoxels per key, in the keys' order
  /// kBlockVoxels per key, in the keys' order; empty when the map carries no colour.
  std::vector<ColourVoxel> colours;
};

/// Puts the blocks of `c` (keys, voxels and colours in any one order) into increasing key order
/// in place, moving each block once: no second copy of the map is needed.
void sort_blocks_by_key(BlockMapContents& c);

/// An owning block map in host memory: the shared storage (BlockMapStore, no direct-mapped
/// tables: the host's raycast is not bound by its lookups) and its counts on the host.
class HostBlockMap {
 public:
  HostBlockMap() = default;
  /// An empty map of `block_capacity` blocks and voxel size grid_size_m / grid_res, with a colour
  /// field when `colour`.
  HostBlockMap(uint32_t block_capacity, int grid_res, float grid_size_m, bool colour = false);

  /// Removes every block (the arrays are kept).
  void clear();
  void clear(const HostMemory&) { clear(); }
  /// Allocates the blocks of `candidates` (packed keys, any order, duplicates allowed; the
  /// vector is sorted and deduplicated in place) that are not in the map yet: in increasing key
  /// order, so the same candidates give the same block indices whatever order they came in.
  /// Once the capacity is reached the rest are dropped and counted.
  BlockAllocation allocate(std::vector<uint64_t>& candidates);
  /// Adds block `key` with the given voxels and colours (null: none yet) (loading a saved map);
  /// throws kfx::Error when the key is present already or the map is full.
  void add_block(uint64_t key, const Voxel* voxels, const ColourVoxel* colours = nullptr);
  /// Coarse cells in use.
  int coarse_count() const { return coarse_count_; }

  /// The blocks in increasing key order (independent of the order they were allocated in),
  /// into `c`, whose arrays' memory is reused (a caller that reads the map repeatedly pays no
  /// fresh allocation).
  void contents_into(BlockMapContents& c) const;
  /// Replaces the map by `contents` (same voxel size; blocks must fit the capacity); every block
  /// is marked touched. Throws kfx::Error on a duplicate key or too many blocks. Colours the
  /// contents lack read as none yet; colours the map has no field for are dropped.
  void load(const BlockMapContents& contents);
  /// load()'s index only: the hashes, keys and touched flags of `contents`' blocks (block i at
  /// index i), with the same checks, and no copy of their voxels or colours, whose storage stays
  /// untouched (for a reader of `contents` itself: view_of_contents, the CUDA upload).
  void load_index(const BlockMapContents& contents);
  /// True when the map carries a colour field.
  bool has_colour() const { return store_.has_colour(); }

  BlockMapView view() { return store_.view(block_count_); }
  /// A view of this map's index (load_index(contents) done last) over `contents`' own voxels and
  /// colours: a block map read without a second copy of its voxels. For reading only, while
  /// `contents` lives.
  BlockMapView view_of_contents(const BlockMapContents& contents);
  /// Blocks allocated.
  int block_count() const { return block_count_; }
  uint32_t block_capacity() const { return store_.capacity; }
  /// Bytes the allocated blocks take (block_bytes each).
  uint64_t used_bytes() const {
    return block_bytes(has_colour()) * static_cast<uint64_t>(block_count_);
  }
  /// Bytes the map holds allocated for its capacity.
  uint64_t reserved_bytes() const { return store_.reserved_bytes(); }
  int grid_res() const { return store_.grid_res; }
  float grid_size_m() const { return store_.grid_size_m; }
  /// The arrays (for copying an index built here to another location).
  const BlockMapStore<HostMemory>& store() const { return store_; }

 private:
  /// Stores a key absent from the map as block block_count_ (in its coarse cell, which is added
  /// when new) and counts it; the caller checked the capacity.
  void insert_new_block(uint64_t key);
  /// A block of known contents (loaded, not allocated): throws kfx::Error when `key` is in the
  /// map already, else stores it (insert_new_block), marks it and its coarse cell touched and
  /// returns its index. The caller checked the capacity and places the voxels.
  int insert_loaded_block(uint64_t key);
  BlockMapStore<HostMemory> store_;
  int coarse_count_ = 0;
  int block_count_ = 0;
};

}  // namespace kfx
