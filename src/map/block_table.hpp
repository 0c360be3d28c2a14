#pragma once
/// A direct-mapped table in front of the block hash (map/block_hash.hpp): block (bx, by, bz) can
/// only sit in entry (bx, by, bz) mod kBlockTableSide, which holds its coordinates and index
/// when it is the only allocated block that maps there. The coarse cells (map/block_map.hpp)
/// have a table of their own in front of their hash. A lookup then costs one 16-byte load and
/// three compares instead of packing the key, hashing it and probing; the GPU's block raycast,
/// bound by its instructions, does several lookups per sample (bench/RESULTS.md, "fewer
/// instructions per block lookup").
///
/// Each entry is in one of three states, whatever order the blocks were inserted in:
/// - empty (index kBlockTableEmpty): no allocated block maps here, so a block that does is absent;
/// - one block (index ≥ 0): that block is present, any other block that maps here is absent;
/// - shared (index kBlockTableShared): two or more blocks map here; the hash answers.
/// So the table answers exactly as the hash would, or defers to it. It only grows with the map
/// (blocks are never deleted); a map that loses blocks (a swap pass) builds it again.

#include <cstdint>

#include "core/math.hpp"

namespace kfx {

/// Entries per table side (log2): 128³ entries of 16 bytes, 32 MiB, covering 5.12 m at 5 mm
/// voxels before two blocks share an entry.
constexpr int kBlockTableSideShift = 7;
constexpr int kBlockTableSide = 1 << kBlockTableSideShift;
constexpr int64_t kBlockTableEntries = int64_t{kBlockTableSide} * kBlockTableSide * kBlockTableSide;
/// Index of an entry no block maps to (every byte 0xff: a memset empties the table).
constexpr int32_t kBlockTableEmpty = -1;
/// Index of an entry two or more blocks map to.
constexpr int32_t kBlockTableShared = -2;
/// What BlockTableView::find returns when the hash must answer.
constexpr int32_t kBlockTableAskHash = -3;

/// One entry: the block's coordinates and index (valid while index ≥ 0). 16-byte aligned, so
/// the GPU reads it in one load.
struct alignas(16) BlockTableEntry {
  int32_t bx, by, bz;
  int32_t index;
};

/// A non-owning view of the table (host or device memory); null entries: no table.
struct BlockTableView {
  BlockTableEntry* entries = nullptr;

  /// Entry of block (bx, by, bz): its coordinates modulo the side (two's complement, so negative
  /// coordinates wrap too).
  KFX_HD static int64_t slot(int bx, int by, int bz) {
    constexpr int m = kBlockTableSide - 1;
    return (bx & m) | ((by & m) << kBlockTableSideShift) |
           (static_cast<int64_t>(bz & m) << (2 * kBlockTableSideShift));
  }
  /// Index of block (bx, by, bz), −1 when absent, or kBlockTableAskHash.
  KFX_HD int32_t find(int bx, int by, int bz) const {
    const BlockTableEntry e = entries[slot(bx, by, bz)];
    if (e.index == kBlockTableShared) return kBlockTableAskHash;
    return e.index >= 0 && e.bx == bx && e.by == by && e.bz == bz ? e.index : -1;
  }
  /// Adds block (bx, by, bz) as index b (b ≥ 0; each block once). Host: one thread at a time.
  /// Device: concurrent insertions end in the same state whatever their order (one block:
  /// its entry; two or more: shared); nothing may read the table until the kernel ends.
  KFX_HD void insert(int bx, int by, int bz, int32_t b) const {
    BlockTableEntry& e = entries[slot(bx, by, bz)];
#if defined(__CUDA_ARCH__)
    const int32_t old = atomicCAS(&e.index, kBlockTableEmpty, b);
#else
    const int32_t old = e.index;
    if (old == kBlockTableEmpty) e.index = b;
#endif
    if (old == kBlockTableEmpty) {
      e.bx = bx;
      e.by = by;
      e.bz = bz;
    } else if (old != kBlockTableShared) {
#if defined(__CUDA_ARCH__)
      atomicExch(&e.index, kBlockTableShared);
#else
      e.index = kBlockTableShared;
#endif
    }
  }
};

}  // namespace kfx
