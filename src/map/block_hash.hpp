#pragma once
/// The hash table of the block map: voxel-block coordinates → block index, open addressing with
/// linear probing over a power-of-two array of slots, usable from host and device code (KFX_HD).
///
/// Why this shape: one probe sequence per key (no buckets and excess list as in InfiniTAM), so a
/// lookup is a short run of 8-byte compares that stops at the first empty slot, and an insert on
/// the GPU is one 64-bit compare-and-swap per probe. The map keeps the load at or below 1/2
/// (slots = the next power of two ≥ 2 × block capacity), where linear probing stays short.
/// Nothing is ever deleted (a block, once allocated, stays until the map is cleared), so the
/// table needs no tombstones.
///
/// Determinism: which block index a key gets is decided by the caller (the map allocates new
/// blocks in sorted key order, map/host_block_map.hpp), never by which thread wins a race; the
/// slot a key lands in may depend on insertion order on the GPU, but a lookup's answer does not.

#include <cstdint>

#include "core/math.hpp"

namespace kfx {

/// Bits per block coordinate in a packed key: coordinates lie in [−2^20, 2^20) (at 5 mm voxels
/// in 8³ blocks, ±41 km).
constexpr int kBlockCoordBits = 21;
/// Smallest coordinate that packs; the largest is −kBlockCoordMin − 1.
constexpr int kBlockCoordMin = -(1 << (kBlockCoordBits - 1));
/// The key of an empty slot: bit 63 set, which no packed key has.
constexpr uint64_t kEmptyBlockKey = ~uint64_t{0};

/// True when block coordinates (bx, by, bz) fit a packed key.
KFX_HD inline bool block_coords_packable(int bx, int by, int bz) {
  const int hi = -kBlockCoordMin;
  return bx >= kBlockCoordMin && bx < hi && by >= kBlockCoordMin && by < hi &&
         bz >= kBlockCoordMin && bz < hi;
}

/// The key of block (bx, by, bz) (block_coords_packable): 21 bits per axis, x lowest. Sorting
/// keys sorts blocks by z, then y, then x.
KFX_HD inline uint64_t pack_block_key(int bx, int by, int bz) {
  constexpr uint64_t mask = (uint64_t{1} << kBlockCoordBits) - 1;
  return (static_cast<uint64_t>(bx - kBlockCoordMin) & mask) |
         ((static_cast<uint64_t>(by - kBlockCoordMin) & mask) << kBlockCoordBits) |
         ((static_cast<uint64_t>(bz - kBlockCoordMin) & mask) << (2 * kBlockCoordBits));
}

/// Block coordinates of a packed key.
KFX_HD inline Vec3i unpack_block_key(uint64_t key) {
  constexpr uint64_t mask = (uint64_t{1} << kBlockCoordBits) - 1;
  return {static_cast<int>(key & mask) + kBlockCoordMin,
          static_cast<int>((key >> kBlockCoordBits) & mask) + kBlockCoordMin,
          static_cast<int>((key >> (2 * kBlockCoordBits)) & mask) + kBlockCoordMin};
}

/// Home slot hash of a key: its two 32-bit halves, each times an odd constant, summed, and the
/// high 16 bits folded onto the low ones (the table keeps the low bits). 32-bit arithmetic only:
/// every lookup of the block raycast and of the allocation computes it, and the GPU raycast is
/// bound by its instructions, so it runs faster than with SplitMix64's finaliser (64-bit
/// multiplies and shifts), with the same answers (bench/RESULTS.md, "fewer instructions per block
/// lookup"). Neighbouring blocks, the keys a map holds, probe no longer than random keys do
/// (tests/test_block_hash.cpp), which a bare multiplicative hash of the packed key did not do in
/// small tables (z, the key's top bits, stayed above the mask).
KFX_HD inline uint64_t block_key_hash(uint64_t key) {
  uint32_t h =
      static_cast<uint32_t>(key) * 0x9e3779b1u + static_cast<uint32_t>(key >> 32) * 0x85ebca77u;
  h ^= h >> 16;
  return h;
}

/// What BlockHashView::insert did.
enum class BlockInsert : int {
  kInserted = 0,  ///< the key is new and now maps to the given value
  kPresent = 1,   ///< the key was there already (its value is left alone)
  kFull = 2,      ///< every slot holds another key: nothing was stored
};

/// A non-owning view of the table (host or device memory): `slot_count` = slot_mask + 1 slots,
/// a power of two, each a key (kEmptyBlockKey when free) and a value.
struct BlockHashView {
  uint64_t* keys = nullptr;
  int32_t* values = nullptr;
  uint32_t slot_mask = 0;

  /// The value stored for `key`, or −1 when the key is absent.
  KFX_HD int32_t find(uint64_t key) const {
    uint32_t slot = static_cast<uint32_t>(block_key_hash(key)) & slot_mask;
    for (uint32_t probe = 0; probe <= slot_mask; ++probe) {
      const uint64_t k = keys[slot];
      if (k == key) return values[slot];
      if (k == kEmptyBlockKey) return -1;
      slot = (slot + 1) & slot_mask;
    }
    return -1;  // a full table without the key
  }

  /// Stores key → value unless the key is present or the table is full. Host: one thread at a
  /// time. Device: distinct keys may be inserted concurrently (one compare-and-swap claims a
  /// slot); the same key from two threads at once returns kPresent to one of them, which must
  /// then not rely on the other's value before the kernel ends (the map inserts deduplicated
  /// keys only). With `slot_out`, the slot that now holds the key (kInserted) is written there,
  /// so a caller may later empty exactly the slots it filled.
  KFX_HD BlockInsert insert(uint64_t key, int32_t value, uint32_t* slot_out = nullptr) const {
    uint32_t slot = static_cast<uint32_t>(block_key_hash(key)) & slot_mask;
    for (uint32_t probe = 0; probe <= slot_mask; ++probe) {
#if defined(__CUDA_ARCH__)
      const unsigned long long old = atomicCAS(reinterpret_cast<unsigned long long*>(&keys[slot]),
                                               static_cast<unsigned long long>(kEmptyBlockKey),
                                               static_cast<unsigned long long>(key));
#else
      const uint64_t old = keys[slot];
      if (old == kEmptyBlockKey) keys[slot] = key;
#endif
      if (old == kEmptyBlockKey) {
        values[slot] = value;
        if (slot_out) *slot_out = slot;
        return BlockInsert::kInserted;
      }
      if (old == key) return BlockInsert::kPresent;
      slot = (slot + 1) & slot_mask;
    }
    return BlockInsert::kFull;
  }
};

/// Slots for a table holding up to `max_keys` keys at a load of at most 1/2: the next power of
/// two ≥ 2 · max_keys (at least 2).
inline uint32_t block_hash_slot_count(uint32_t max_keys) {
  uint32_t slots = 2;
  while (slots < 2 * static_cast<uint64_t>(max_keys)) slots <<= 1;
  return slots;
}

}  // namespace kfx
