#pragma once
/// The sparse map (setting `volume=blocks`): 8³ voxel blocks, allocated where a frame's
/// truncation band falls and found through the block hash (map/block_hash.hpp), over an
/// unbounded grid of voxel coordinates (negative ones included). The dense cube (VolumeView,
/// core/volume.hpp) is the other kind of map; the kernel bodies read either through the same
/// questions (the voxel at (x, y, z), the block at (bx, by, bz)), so a per-voxel body does not
/// know which it reads.
///
/// Voxel (x, y, z) has its centre at ((x + ½)·v, (y + ½)·v, (z + ½)·v), v = grid_size_m /
/// grid_res, exactly as in the dense cube of that size and resolution: a block map set up with
/// a dense run's size and resolution computes every voxel's position with the same float
/// operations, so both integrate the same values where both hold the voxel.

#include <cstdint>

#include "core/colour_volume.hpp"
#include "core/math.hpp"
#include "core/volume.hpp"
#include "map/block_hash.hpp"
#include "map/block_table.hpp"

namespace kfx {

/// Voxels per block side (the dense cube's brick: both skip empty space in the same units).
constexpr int kBlockSide = 1 << kBrickShift;
/// Voxels per block.
constexpr int kBlockVoxels = kBlockSide * kBlockSide * kBlockSide;
/// Blocks per coarse cell side (log2): a coarse cell of 4³ blocks (32³ voxels) carries a
/// "touched" flag, so the raycast crosses large unobserved or empty regions in few tests (the
/// dense cube's super-bricks, kSuperBrickShift, do the same with a plain array).
constexpr int kCoarseShift = 2;
/// Voxels per coarse cell side (log2).
constexpr int kCoarseVoxelShift = kBrickShift + kCoarseShift;

/// Block coordinate of voxel coordinate c (floor division by kBlockSide, negatives included).
KFX_HD inline int block_of_voxel(int c) { return c >> kBrickShift; }  // arithmetic shift

/// Index of voxel (x, y, z) inside its block: x fastest.
KFX_HD inline int voxel_in_block(int x, int y, int z) {
  constexpr int m = kBlockSide - 1;
  return (x & m) + ((y & m) << kBrickShift) + ((z & m) << (2 * kBrickShift));
}

/// The empty voxel: tsdf +1, weight 0 (what an unallocated voxel reads as).
KFX_HD inline Voxel empty_voxel() { return Voxel{static_cast<int16_t>(kTsdfScale), 0}; }

/// Value of cell (x, y, z) (a block, or a coarse cell) in `hash`, asked of `table` first where
/// there is one; −1 when absent or not packable.
KFX_HD inline int32_t find_in_table_or_hash(const BlockTableView& table, const BlockHashView& hash,
                                            int x, int y, int z) {
  if (table.entries) {
    const int32_t found = table.find(x, y, z);
    if (found != kBlockTableAskHash) return found;
  }
  if (!block_coords_packable(x, y, z)) return -1;
  return hash.find(pack_block_key(x, y, z));
}

/// A non-owning view of a block map (host or device memory).
struct BlockMapView {
  BlockHashView hash;  ///< packed block key → block index
  /// The direct-mapped table in front of the hash (map/block_table.hpp); the GPU's map keeps
  /// one, the host's none (null entries: every lookup asks the hash).
  BlockTableView table;
  Voxel* voxels = nullptr;         ///< block i's voxels at [i·kBlockVoxels, (i+1)·kBlockVoxels)
  uint64_t* block_keys = nullptr;  ///< packed key of block i
  /// One byte per block: 0 while every voxel of the block still stores a tsdf of at least
  /// kMarkBelowTsdfStored (VolumeView::brick_touched's rule), so the raycast may step over it.
  uint8_t* block_touched = nullptr;
  /// The coarse level: coarse cell key (the block key of (bx, by, bz) >> kCoarseShift) → coarse
  /// index, and one flag per coarse cell: 1 once any of its blocks is touched.
  BlockHashView coarse_hash;
  BlockTableView coarse_table;  ///< in front of coarse_hash, as `table` is in front of `hash`
  uint8_t* coarse_touched = nullptr;
  /// Coarse index of block i (so integration sets the coarse flag without a lookup).
  int32_t* block_coarse = nullptr;
  int block_capacity = 0;  ///< blocks the arrays hold
  int block_count = 0;     ///< blocks allocated (indices 0 .. block_count − 1)
  /// Voxel size = grid_size_m / grid_res (kept as this ratio: see the file comment).
  int grid_res = 1;
  float grid_size_m = 0.01f;
  /// The colour field (setting colour): block i's colours at [i·kBlockVoxels, (i+1)·kBlockVoxels),
  /// laid out as its voxels; null when the map carries no colour.
  ColourVoxel* colours = nullptr;

  KFX_HD float voxel_m() const { return grid_size_m / grid_res; }
  /// Voxel centre in the map frame, metres (voxel_centre_m, as the cube).
  KFX_HD Vec3f centre_m(int x, int y, int z) const { return voxel_centre_m(x, y, z, voxel_m()); }
  /// Index of block (bx, by, bz), or −1 when it is not allocated (or cannot be).
  KFX_HD int32_t find_block(int bx, int by, int bz) const {
    return find_in_table_or_hash(table, hash, bx, by, bz);
  }
  /// Index of coarse cell (cx, cy, cz) (block coordinates >> kCoarseShift), or −1.
  KFX_HD int32_t find_coarse(int cx, int cy, int cz) const {
    return find_in_table_or_hash(coarse_table, coarse_hash, cx, cy, cz);
  }
  /// Index of the block holding voxel (x, y, z), or −1.
  KFX_HD int32_t block_of(int x, int y, int z) const {
    return find_block(block_of_voxel(x), block_of_voxel(y), block_of_voxel(z));
  }
  /// Voxel (x, y, z); the empty voxel where no block holds it.
  KFX_HD Voxel voxel(int x, int y, int z) const {
    const int32_t b = block_of(x, y, z);
    return b < 0 ? empty_voxel() : voxels[b * kBlockVoxels + voxel_in_block(x, y, z)];
  }
  /// Voxels of block index b.
  KFX_HD Voxel* block_voxels(int32_t b) const { return voxels + b * kBlockVoxels; }
  /// Block coordinates of block index b.
  KFX_HD Vec3i block_coords(int32_t b) const { return unpack_block_key(block_keys[b]); }
  /// True when block index b may hold a voxel below kMarkBelowTsdfStored (b ≥ 0).
  KFX_HD bool block_is_touched(int32_t b) const { return block_touched[b] != 0; }

  // The read interface shared with VolumeView (core/volume.hpp): no faces, nothing to clamp.
  KFX_HD int clamp_lo(int i) const { return i; }
  KFX_HD int clamp_hi(int i) const { return i; }
  KFX_HD bool box_open_above(int) const { return false; }
  KFX_HD bool box_open_below(int) const { return false; }
  KFX_HD int16_t stored_tsdf(int x, int y, int z) const { return voxel(x, y, z).tsdf; }
};

KFX_HD inline int map_grid_res(const BlockMapView& v) { return v.grid_res; }
KFX_HD inline float map_grid_size_m(const BlockMapView& v) { return v.grid_size_m; }

/// Reads voxels of a block map, remembering the last block it found: neighbouring reads (the
/// 8 voxels of a trilinear sample, the 32 of a gradient) mostly fall in one block, so they cost
/// one hash lookup instead of one each.
struct BlockMapReader {
  const BlockMapView* map;
  Vec3i block{kBlockCoordMin - 1, 0, 0};  ///< the remembered block (none yet)
  const Voxel* voxels = nullptr;          ///< its voxels, null when unallocated

  /// Voxels of the block holding voxel (x, y, z), or null.
  KFX_HD const Voxel* block_voxels_of(int x, int y, int z) {
    const int bx = block_of_voxel(x), by = block_of_voxel(y), bz = block_of_voxel(z);
    if (bx != block.x || by != block.y || bz != block.z) {
      block = {bx, by, bz};
      const int32_t b = map->find_block(bx, by, bz);
      voxels = b < 0 ? nullptr : map->block_voxels(b);
    }
    return voxels;
  }
  KFX_HD Voxel voxel(int x, int y, int z) {
    const Voxel* v = block_voxels_of(x, y, z);
    return v ? v[voxel_in_block(x, y, z)] : empty_voxel();
  }
  KFX_HD int16_t stored_tsdf(int x, int y, int z) { return voxel(x, y, z).tsdf; }
  // The rest of the read interface (VolumeView's), for the marching-cubes bodies.
  KFX_HD int clamp_lo(int i) const { return i; }
  KFX_HD int clamp_hi(int i) const { return i; }
  KFX_HD bool contains(int, int, int) const { return true; }
  KFX_HD bool contains_cell(int, int, int) const { return true; }
  KFX_HD float voxel_m() const { return map->voxel_m(); }
};

/// A reader of the block map (BlockMapReader).
KFX_HD inline BlockMapReader map_reader(const BlockMapView& v) { return BlockMapReader{&v}; }

/// What a ray of the raycast remembers from sample to sample (raycast_ray keeps one): the last
/// block and the last coarse cell it found touched, so untouched_sample need not look them up
/// again, and a trilinear sample's reader starts with that block's voxels (map_reader).
struct BlockMapRayMemo {
  Vec3i block{kBlockCoordMin - 1, 0, 0};   ///< none yet (no packable block has this x)
  const Voxel* voxels = nullptr;           ///< the block's voxels
  Vec3i coarse{kBlockCoordMin - 1, 0, 0};  ///< none yet
};
KFX_HD inline BlockMapRayMemo ray_memo(const BlockMapView&) { return BlockMapRayMemo{}; }
/// A reader of the block map that already holds the memo's block (no lookup while the reads
/// stay in it), or (NoRayMemo) a fresh one.
KFX_HD inline BlockMapReader map_reader(const BlockMapView& v, const BlockMapRayMemo& m) {
  return BlockMapReader{&v, m.block, m.voxels};
}
KFX_HD inline BlockMapReader map_reader(const BlockMapView& v, const NoRayMemo&) {
  return map_reader(v);
}

/// True when voxels [lo, hi] (per axis) all lie in the cube of 2^shift voxels at cube
/// coordinates c.
KFX_HD inline bool voxels_in_cube(const int lo[3], const int hi[3], int shift, const Vec3i& c) {
  return (lo[0] >> shift) == c.x && (hi[0] >> shift) == c.x && (lo[1] >> shift) == c.y &&
         (hi[1] >> shift) == c.y && (lo[2] >> shift) == c.z && (hi[2] >> shift) == c.z;
}
/// True when voxels [lo, hi] all lie in the memo's touched block / coarse cell (never without a
/// memo).
KFX_HD inline bool memo_holds_block(const NoRayMemo&, const int*, const int*) { return false; }
KFX_HD inline bool memo_holds_block(const BlockMapRayMemo& m, const int lo[3], const int hi[3]) {
  return voxels_in_cube(lo, hi, kBrickShift, m.block);
}
KFX_HD inline bool memo_holds_coarse(const NoRayMemo&, const int*, const int*) { return false; }
KFX_HD inline bool memo_holds_coarse(const BlockMapRayMemo& m, const int lo[3], const int hi[3]) {
  return voxels_in_cube(lo, hi, kCoarseVoxelShift, m.coarse);
}
/// Remembers a touched block / coarse cell (nothing without a memo).
KFX_HD inline void remember_block(NoRayMemo&, int, int, int, const Voxel*) {}
KFX_HD inline void remember_block(BlockMapRayMemo& m, int bx, int by, int bz, const Voxel* voxels) {
  m.block = {bx, by, bz};
  m.voxels = voxels;
}
KFX_HD inline void remember_coarse(NoRayMemo&, int, int, int) {}
KFX_HD inline void remember_coarse(BlockMapRayMemo& m, int cx, int cy, int cz) {
  m.coarse = {cx, cy, cz};
}

/// The voxels of one allocated block, seen with global voxel coordinates (x, y, z) as a volume:
/// what the per-voxel integration body writes through (IntegrateArgsT<OneBlockView>), so it
/// reads the same for a block as for the dense cube.
struct OneBlockView {
  Voxel* data = nullptr;              ///< the block's kBlockVoxels voxels
  uint8_t* touched = nullptr;         ///< the block's flag (BlockMapView::block_touched)
  uint8_t* coarse_touched = nullptr;  ///< its coarse cell's flag (BlockMapView::coarse_touched)
  Vec3i origin_vox{0, 0, 0};          ///< voxel coordinates of the block's voxel 0
  int grid_res = 1;
  float grid_size_m = 0.01f;
  ColourVoxel* colour = nullptr;  ///< the block's kBlockVoxels colours; null without colour

  KFX_HD float voxel_m() const { return grid_size_m / grid_res; }
  KFX_HD Vec3f centre_m(int x, int y, int z) const { return voxel_centre_m(x, y, z, voxel_m()); }
  /// Voxel (x, y, z), which must lie in this block.
  KFX_HD Voxel& at(int x, int y, int z) const { return data[voxel_in_block(x, y, z)]; }
  /// Colour of voxel (x, y, z), which must lie in this block (colour non-null).
  KFX_HD ColourVoxel& colour_at(int x, int y, int z) const {
    return colour[voxel_in_block(x, y, z)];
  }
  /// Marks the block touched (one writer per block: no race) and its coarse cell (shared with
  /// other blocks: set_shared_flag).
  KFX_HD void mark_touched(int, int, int) const {
    if (!*touched) {
      *touched = 1;
      set_shared_flag(*coarse_touched);
    }
  }
};

/// The block view of block index b of `map`.
KFX_HD inline OneBlockView one_block_view(const BlockMapView& map, int32_t b) {
  const Vec3i c = map.block_coords(b);
  return OneBlockView{
      map.block_voxels(b),
      map.block_touched + b,
      map.coarse_touched + map.block_coarse[b],
      Vec3i{c.x * kBlockSide, c.y * kBlockSide, c.z * kBlockSide},
      map.grid_res,
      map.grid_size_m,
      map.colours ? map.colours + static_cast<long long>(b) * kBlockVoxels : nullptr};
}

/// The colour of voxel (x, y, z) of a block map; weight 0 (no colour) where no block holds it
/// or the map has no colour field.
KFX_HD inline ColourVoxel map_colour_voxel(const BlockMapView& map, int x, int y, int z) {
  const int32_t b = map.colours ? map.block_of(x, y, z) : -1;
  return b < 0 ? ColourVoxel{0, 0, 0, 0}
               : map.colours[static_cast<long long>(b) * kBlockVoxels + voxel_in_block(x, y, z)];
}

/// Colour at map-frame point p_m (sample_colour's trilinear rule over the block map's colour
/// field); false where none of the eight voxels around it holds colour.
KFX_HD inline bool sample_colour(const BlockMapView& map, Vec3f p_m, Vec3f& rgb) {
  if (!map.colours) return false;
  return sample_colour_field(map.grid_res / map.grid_size_m, p_m, rgb,
                             [&](int x, int y, int z) { return map_colour_voxel(map, x, y, z); });
}

}  // namespace kfx
