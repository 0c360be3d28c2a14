#pragma once
/// Swapping a block map's far blocks out of the active map (settings map_swap,
/// map_swap_distance_m): InfiniTAM's host swapping, done in passes. The active map (on the
/// backend, device memory on the GPU) holds the blocks near the camera; a pass moves the blocks
/// whose centres lie beyond a distance from the camera into a store in host memory and brings
/// the store's blocks within that distance back. Mesh, cloud and save read the union.
///
/// A key can end up in both places: a block the band reaches again before a pass brings its
/// old copy back is allocated afresh. The two copies then hold disjoint sets of measurements,
/// and merge_voxel fuses them into one running average, as integration would have.
/// docs/map.md ("Swapping") gives the rules and their cost.

#include <cstdint>
#include <initializer_list>

#include "core/math.hpp"
#include "map/host_block_map.hpp"

namespace kfx {

/// Weight caps of a merge, in the units the voxels store.
struct VoxelWeightCaps {
  int tsdf = 100;    ///< max_weight × kWeightUnits with weighted integration, else max_weight
  int colour = 100;  ///< max_weight
};

/// Voxel a and b, holding disjoint measurements of one place, as one running average: the
/// weighted mean of their tsdfs, rounded to the nearest stored value, with their summed weight
/// (capped). A voxel of weight 0 adds nothing.
Voxel merge_voxel(Voxel a, Voxel b, int tsdf_weight_cap);
/// The same for a colour voxel.
ColourVoxel merge_colour(ColourVoxel a, ColourVoxel b, int colour_weight_cap);

/// The union of two maps' contents (each in increasing key order, the same voxel size), in
/// increasing key order; a block both hold is merged voxel by voxel. Colours are kept when
/// either side has them (the other side's blocks then have none yet).
BlockMapContents merge_contents(const BlockMapContents& a, const BlockMapContents& b,
                                const VoxelWeightCaps& caps);
/// The same into `out` (neither a nor b), reusing its arrays' memory; returns how many keys
/// both held.
int merge_contents_into(const BlockMapContents& a, const BlockMapContents& b,
                        const VoxelWeightCaps& caps, BlockMapContents& out);

/// Distance in metres from `point_m` to the centre of block `key` of a map of voxel `voxel_m`.
float block_centre_distance_m(uint64_t key, float voxel_m, Vec3f point_m);

/// What one pass did.
struct SwapPassResult {
  int swapped_out = 0;  ///< blocks moved from the active map to the store
  int swapped_in = 0;   ///< blocks moved from the store to the active map
  int merged = 0;       ///< keys both held, fused into one block
};

/// The host store of swapped-out blocks and the pass that fills and empties it.
class BlockSwapStore {
 public:
  explicit BlockSwapStore(VoxelWeightCaps caps = {}) : caps_(caps) {}

  /// One pass: the blocks of `active` whose centres lie farther than `distance_m` from
  /// `camera_m` move to the store (merged with the store's copy of the same key); the store's
  /// blocks within `distance_m` come back, nearest first, as long as the active map stays at
  /// most `max_active_blocks` (merged with active's copy of the same key). `active` becomes the
  /// new active contents, in increasing key order; it is left untouched when no block moves
  /// (the result's counts are then 0).
  SwapPassResult pass(BlockMapContents& active, Vec3f camera_m, float distance_m,
                      int max_active_blocks);
  /// The active map's contents with the store's blocks, merged (what mesh, cloud and save read).
  BlockMapContents with_store(const BlockMapContents& active) const;
  /// Blocks in the store.
  int block_count() const { return static_cast<int>(store_.keys.size()); }
  /// True when nothing is stored.
  bool empty() const { return store_.keys.empty(); }
  /// Empties the store (and frees the pass's working copies).
  void clear() { *this = BlockSwapStore(caps_); }
  /// Frees the pass's working copies (the store stays); the next pass allocates them afresh.
  void release_working_memory() {
    // Each from a temporary: a move frees the old arrays, where a copy of an empty one would
    // keep their capacity.
    for (BlockMapContents* c : {&kept_, &out_, &returning_, &scratch_}) *c = BlockMapContents{};
  }

 private:
  VoxelWeightCaps caps_;
  BlockMapContents store_;  ///< increasing key order
  /// A pass's working copies, kept between passes so that later passes reuse their memory
  /// (fresh arrays of hundreds of megabytes cost more in page faults than the copying).
  BlockMapContents kept_, out_, returning_, scratch_;
};

}  // namespace kfx
