/// The block hash (map/block_hash.hpp) and the host block map's allocation
/// (map/host_block_map.hpp): properties at high load, forced collisions, a full table, and
/// deterministic block indices.

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <vector>

#include "map/block_hash.hpp"
#include "map/host_block_map.hpp"

namespace kfx {
namespace {

/// A table of `slots` slots (a power of two) in vectors.
struct Table {
  explicit Table(uint32_t slots) : keys(slots, kEmptyBlockKey), values(slots, -1) {}
  BlockHashView view() {
    return BlockHashView{keys.data(), values.data(), static_cast<uint32_t>(keys.size() - 1)};
  }
  std::vector<uint64_t> keys;
  std::vector<int32_t> values;
};

uint64_t random_key(std::mt19937_64& rng) {
  std::uniform_int_distribution<int> coord(kBlockCoordMin, -kBlockCoordMin - 1);
  return pack_block_key(coord(rng), coord(rng), coord(rng));
}

TEST(BlockHash, PackedKeysRoundTripAtTheRangeLimitsAndNeverEqualTheEmptyKey) {
  const int lo = kBlockCoordMin, hi = -kBlockCoordMin - 1;
  for (int x : {lo, lo + 1, -1, 0, 1, hi - 1, hi}) {
    for (int y : {lo, -1, 0, hi}) {
      for (int z : {lo, -7, 0, 5, hi}) {
        ASSERT_TRUE(block_coords_packable(x, y, z));
        const uint64_t key = pack_block_key(x, y, z);
        EXPECT_NE(key, kEmptyBlockKey);
        const Vec3i back = unpack_block_key(key);
        EXPECT_EQ(back.x, x);
        EXPECT_EQ(back.y, y);
        EXPECT_EQ(back.z, z);
      }
    }
  }
  EXPECT_FALSE(block_coords_packable(hi + 1, 0, 0));
  EXPECT_FALSE(block_coords_packable(0, lo - 1, 0));
  // Keys sort by z, then y, then x (the map allocates in this order).
  EXPECT_LT(pack_block_key(5, 0, 0), pack_block_key(-5, 1, 0));
  EXPECT_LT(pack_block_key(5, 5, -1), pack_block_key(-5, -5, 0));
}

TEST(BlockHash, EveryKeyIsFoundAtLoadsUpToAFullTable) {
  std::mt19937_64 rng(7);
  for (const double load : {0.5, 0.9, 0.99, 1.0}) {
    Table table(1024);
    const BlockHashView hash = table.view();
    const int n = static_cast<int>(load * 1024);
    std::map<uint64_t, int32_t> model;
    while (static_cast<int>(model.size()) < n) {
      const uint64_t key = random_key(rng);
      if (model.count(key)) continue;
      const int32_t value = static_cast<int32_t>(model.size());
      ASSERT_EQ(hash.insert(key, value), BlockInsert::kInserted) << "load " << load;
      model[key] = value;
    }
    for (const auto& [key, value] : model) {
      EXPECT_EQ(hash.find(key), value);
      EXPECT_EQ(hash.insert(key, 12345), BlockInsert::kPresent);
      EXPECT_EQ(hash.find(key), value) << "a present key's value must stay";
    }
    // Absent keys are reported absent, also when the table is full (the probe ends).
    for (int i = 0; i < 200; ++i) {
      const uint64_t key = random_key(rng);
      if (!model.count(key)) EXPECT_EQ(hash.find(key), -1);
    }
    if (n == 1024) EXPECT_EQ(hash.insert(random_key(rng), 1), BlockInsert::kFull);
  }
}

TEST(BlockHash, KeysSharingOneHomeSlotAreAllFoundAcrossTheWrapAround) {
  // Keys whose home slot is the last one: their probe runs wrap to slot 0.
  Table table(64);
  const BlockHashView hash = table.view();
  std::vector<uint64_t> colliding;
  for (int x = 0; colliding.size() < 40; ++x) {
    const uint64_t key = pack_block_key(x, -x, 3);
    if ((block_key_hash(key) & 63) == 63) colliding.push_back(key);
  }
  for (size_t i = 0; i < colliding.size(); ++i) {
    ASSERT_EQ(hash.insert(colliding[i], static_cast<int32_t>(i)), BlockInsert::kInserted);
  }
  for (size_t i = 0; i < colliding.size(); ++i) {
    EXPECT_EQ(hash.find(colliding[i]), static_cast<int32_t>(i));
  }
  EXPECT_EQ(std::count(table.keys.begin(), table.keys.end(), kEmptyBlockKey), 64 - 40);
  EXPECT_NE(table.keys[0], kEmptyBlockKey) << "the run should have wrapped to slot 0";
}

/// Slots a lookup of `key` (present) reads: its distance from its home slot, plus one.
int probe_length(const Table& table, uint64_t key) {
  const uint32_t mask = static_cast<uint32_t>(table.keys.size() - 1);
  uint32_t slot = static_cast<uint32_t>(block_key_hash(key)) & mask;
  int probes = 1;
  while (table.keys[slot] != key) {
    slot = (slot + 1) & mask;
    ++probes;
  }
  return probes;
}

TEST(BlockHash, NeighbouringBlocksProbeNoLongerThanRandomKeys) {
  // A map's keys are neighbours: a solid slab of blocks, a box's shell and a small block of
  // blocks, each in a table sized as the map sizes it. Linear probing over random keys reads
  // 1.5 slots per lookup of a present key at a load of 1/2; a hash that kept the coordinates'
  // regularity piles neighbours into runs (the high half of the packed key times 2^64/φ did, on
  // the slab and the small set).
  std::vector<std::vector<uint64_t>> sets(3);
  for (int z = -8; z < 8; ++z) {
    for (int y = -40; y < 24; ++y) {
      for (int x = -30; x < 34; ++x) sets[0].push_back(pack_block_key(x, y, z));
    }
  }
  for (int z = 0; z <= 80; ++z) {
    for (int y = 0; y <= 40; ++y) {
      for (int x = 0; x <= 120; ++x) {
        const bool wall = x < 2 || x > 118 || y < 2 || y > 38 || z < 2 || z > 78;
        if (wall) sets[1].push_back(pack_block_key(x - 1000, y + 7, z - 300));
      }
    }
  }
  for (int z = 0; z < 4; ++z) {
    for (int y = 0; y < 32; ++y) {
      for (int x = 0; x < 32; ++x) sets[2].push_back(pack_block_key(x, y, z));
    }
  }
  for (const std::vector<uint64_t>& keys : sets) {
    Table table(block_hash_slot_count(static_cast<uint32_t>(keys.size())));
    const BlockHashView hash = table.view();
    for (size_t i = 0; i < keys.size(); ++i) {
      ASSERT_EQ(hash.insert(keys[i], static_cast<int32_t>(i)), BlockInsert::kInserted);
    }
    double sum = 0.0;
    int longest = 0;
    for (uint64_t key : keys) {
      const int probes = probe_length(table, key);
      sum += probes;
      longest = std::max(longest, probes);
    }
    const double load = static_cast<double>(keys.size()) / static_cast<double>(table.keys.size());
    EXPECT_GT(load, 0.25);
    EXPECT_LE(sum / static_cast<double>(keys.size()), 1.6) << keys.size() << " keys";
    EXPECT_LE(longest, 32) << keys.size() << " keys";
  }
}

TEST(BlockHash, SlotCountKeepsTheLoadAtMostAHalf) {
  EXPECT_EQ(block_hash_slot_count(0), 2u);
  EXPECT_EQ(block_hash_slot_count(1), 2u);
  EXPECT_EQ(block_hash_slot_count(3), 8u);
  EXPECT_EQ(block_hash_slot_count(512), 1024u);
  EXPECT_EQ(block_hash_slot_count(513), 2048u);
}

TEST(HostBlockMap, AllocationOrderDoesNotDependOnTheCandidatesOrder) {
  std::mt19937_64 rng(11);
  std::vector<uint64_t> candidates;
  for (int i = 0; i < 3000; ++i) {
    std::uniform_int_distribution<int> c(-20, 20);
    candidates.push_back(pack_block_key(c(rng), c(rng), c(rng)));
  }
  std::vector<uint64_t> first_keys;
  for (int run = 0; run < 3; ++run) {
    std::vector<uint64_t> shuffled = candidates;
    std::shuffle(shuffled.begin(), shuffled.end(), rng);
    HostBlockMap map(4000, 256, 2.0f);
    const BlockAllocation a = map.allocate(shuffled);
    EXPECT_EQ(a.dropped, 0);
    EXPECT_EQ(a.allocated, map.block_count());
    const BlockMapView view = map.view();
    std::vector<uint64_t> keys(view.block_keys, view.block_keys + map.block_count());
    EXPECT_TRUE(std::is_sorted(keys.begin(), keys.end()));
    for (int b = 0; b < map.block_count(); ++b) EXPECT_EQ(view.hash.find(keys[b]), b);
    if (run == 0) first_keys = keys;
    EXPECT_EQ(keys, first_keys);
  }
}

TEST(HostBlockMap, ContentsPutBlocksInKeyOrderEachWithItsOwnVoxelsAndColours) {
  // Blocks added in shuffled key order (so stored out of key order); each block's voxels and
  // colours carry its storage index, so a block that travelled without its data shows.
  std::mt19937_64 rng(5);
  std::vector<uint64_t> keys;
  for (int i = 0; i < 200; ++i) keys.push_back(pack_block_key(i, -i, i % 7));
  std::shuffle(keys.begin(), keys.end(), rng);
  const size_t n = keys.size();
  for (const bool colour : {true, false}) {
    HostBlockMap map(256, 256, 2.0f, colour);
    for (size_t b = 0; b < n; ++b) {
      std::vector<Voxel> voxels(kBlockVoxels);
      std::vector<ColourVoxel> colours(kBlockVoxels);
      for (int v = 0; v < kBlockVoxels; ++v) {
        voxels[v] = Voxel{static_cast<int16_t>(b), static_cast<int16_t>(v)};
        colours[v] = ColourVoxel{static_cast<uint16_t>(b), 0, 0, static_cast<uint16_t>(v)};
      }
      map.add_block(keys[b], voxels.data(), colours.data());
    }
    BlockMapContents out;
    out.keys = {1, 2, 3};  // stale contents: replaced, not appended to
    out.colours.resize(7);
    map.contents_into(out);
    ASSERT_EQ(out.keys.size(), n);
    EXPECT_TRUE(std::is_sorted(out.keys.begin(), out.keys.end()));
    EXPECT_EQ(out.grid_res, 256);
    EXPECT_EQ(out.grid_size_m, 2.0f);
    ASSERT_EQ(out.voxels.size(), n * kBlockVoxels);
    // Without a colour field the contents have no colours, even where the array held some.
    ASSERT_EQ(out.colours.size(), colour ? n * kBlockVoxels : 0);
    for (size_t i = 0; i < n; ++i) {
      const size_t b =
          static_cast<size_t>(std::find(keys.begin(), keys.end(), out.keys[i]) - keys.begin());
      for (int v = 0; v < kBlockVoxels; v += 37) {
        EXPECT_EQ(out.voxels[i * kBlockVoxels + v].tsdf, static_cast<int16_t>(b));
        EXPECT_EQ(out.voxels[i * kBlockVoxels + v].weight, static_cast<int16_t>(v));
        if (!colour) continue;
        EXPECT_EQ(out.colours[i * kBlockVoxels + v].r, static_cast<uint16_t>(b));
        EXPECT_EQ(out.colours[i * kBlockVoxels + v].weight, static_cast<uint16_t>(v));
      }
    }
  }
}

TEST(HostBlockMap, AnIndexOverContentsReadsWhatTheLoadedMapReads) {
  // Contents with distinct voxels and colours per block; a map loaded from them (its own
  // copy) and an index over them (the contents' arrays) must find every block at the same
  // index with the same data.
  BlockMapContents c;
  c.grid_res = 256;
  c.grid_size_m = 2.0f;
  for (int b = 0; b < 150; ++b) c.keys.push_back(pack_block_key(b % 9 - 4, b / 9 - 8, b % 5));
  std::sort(c.keys.begin(), c.keys.end());
  for (size_t i = 0; i < c.keys.size() * kBlockVoxels; ++i) {
    c.voxels.push_back(Voxel{static_cast<int16_t>(i % 30011), static_cast<int16_t>(i % 101)});
    c.colours.push_back(ColourVoxel{static_cast<uint16_t>(i % 65521), 7, 8, 1});
  }
  HostBlockMap loaded(200, 256, 2.0f, true);
  loaded.load(c);
  HostBlockMap index(200, 256, 2.0f, true);
  index.load_index(c);
  const BlockMapView a = loaded.view();
  const BlockMapView b = index.view_of_contents(c);
  EXPECT_EQ(b.voxels, c.voxels.data());
  EXPECT_EQ(b.colours, c.colours.data());
  ASSERT_EQ(a.block_count, b.block_count);
  for (const uint64_t key : c.keys) {
    const int32_t slot = a.hash.find(key);
    ASSERT_GE(slot, 0);
    ASSERT_EQ(b.hash.find(key), slot);
    EXPECT_EQ(a.block_touched[slot], b.block_touched[slot]);
    EXPECT_EQ(a.coarse_touched[a.block_coarse[slot]], b.coarse_touched[b.block_coarse[slot]]);
    for (int v = 0; v < kBlockVoxels; v += 41) {
      const size_t i = static_cast<size_t>(slot) * kBlockVoxels + v;
      EXPECT_EQ(a.voxels[i].tsdf, b.voxels[i].tsdf);
      EXPECT_EQ(a.voxels[i].weight, b.voxels[i].weight);
      EXPECT_EQ(a.colours[i].r, b.colours[i].r);
    }
  }
  // An index serves only the contents it was loaded from.
  BlockMapContents other = c;
  other.keys.pop_back();
  other.voxels.resize(other.keys.size() * kBlockVoxels);
  other.colours.clear();
  EXPECT_THROW(index.view_of_contents(other), Error);
  // load_index checks what load checks: a repeated key, too many blocks.
  BlockMapContents twice = other;
  twice.keys.back() = twice.keys.front();
  EXPECT_THROW(index.load_index(twice), Error);
  HostBlockMap small(100, 256, 2.0f);
  EXPECT_THROW(small.load_index(c), Error);
}

TEST(HostBlockMap, SortInPlaceGivesEachKeyItsOwnBlock) {
  std::mt19937_64 rng(9);
  for (const size_t n : {size_t{0}, size_t{1}, size_t{2}, size_t{257}}) {
    for (const bool colour : {false, true}) {
      BlockMapContents c;
      c.grid_res = 512;
      c.grid_size_m = 2.56f;
      for (size_t b = 0; b < n; ++b) {
        c.keys.push_back(pack_block_key(static_cast<int>(b) - 100, static_cast<int>(b % 5), 3));
      }
      std::shuffle(c.keys.begin(), c.keys.end(), rng);
      std::uniform_int_distribution<int> value(-30000, 30000);
      for (size_t i = 0; i < n * kBlockVoxels; ++i) {
        c.voxels.push_back(Voxel{static_cast<int16_t>(value(rng)), static_cast<int16_t>(i % 97)});
        if (colour) c.colours.push_back(ColourVoxel{static_cast<uint16_t>(i), 1, 2, 3});
      }
      // The expected result, gathered block by block through a key → position table.
      std::map<uint64_t, size_t> position;
      for (size_t b = 0; b < n; ++b) position[c.keys[b]] = b;
      BlockMapContents expected;
      for (const auto& [key, b] : position) {
        expected.keys.push_back(key);
        expected.voxels.insert(expected.voxels.end(), c.voxels.begin() + b * kBlockVoxels,
                               c.voxels.begin() + (b + 1) * kBlockVoxels);
        if (colour) {
          expected.colours.insert(expected.colours.end(), c.colours.begin() + b * kBlockVoxels,
                                  c.colours.begin() + (b + 1) * kBlockVoxels);
        }
      }
      sort_blocks_by_key(c);
      EXPECT_EQ(c.keys, expected.keys) << n << " blocks";
      ASSERT_EQ(c.voxels.size(), expected.voxels.size());
      for (size_t i = 0; i < c.voxels.size(); ++i) {
        ASSERT_EQ(c.voxels[i].tsdf, expected.voxels[i].tsdf) << "voxel " << i;
        ASSERT_EQ(c.voxels[i].weight, expected.voxels[i].weight) << "voxel " << i;
      }
      ASSERT_EQ(c.colours.size(), expected.colours.size());
      for (size_t i = 0; i < c.colours.size(); ++i) {
        ASSERT_EQ(c.colours[i].r, expected.colours[i].r) << "colour " << i;
      }
    }
  }
  BlockMapContents torn;
  torn.keys = {1, 2};
  torn.voxels.resize(kBlockVoxels);  // one block's voxels for two keys
  EXPECT_THROW(sort_blocks_by_key(torn), Error);
}

TEST(HostBlockMap, AFullMapDropsAndCountsTheRestAndKeepsWhatItHas) {
  HostBlockMap map(10, 256, 2.0f);
  std::vector<uint64_t> first;
  for (int x = 0; x < 6; ++x) first.push_back(pack_block_key(x, 0, 0));
  EXPECT_EQ(map.allocate(first).allocated, 6);
  std::vector<uint64_t> second;
  for (int x = 0; x < 12; ++x) second.push_back(pack_block_key(x, 1, 0));
  second.push_back(pack_block_key(2, 0, 0));  // present: neither new nor dropped
  const BlockAllocation a = map.allocate(second);
  EXPECT_EQ(a.allocated, 4);
  EXPECT_EQ(a.dropped, 8);
  EXPECT_EQ(map.block_count(), 10);
  const BlockMapView view = map.view();
  for (int x = 0; x < 6; ++x) EXPECT_EQ(view.find_block(x, 0, 0), x);
  for (int x = 0; x < 4; ++x) EXPECT_EQ(view.find_block(x, 1, 0), 6 + x);
  EXPECT_EQ(view.find_block(4, 1, 0), -1);
  // Unallocated voxels read as empty; allocated ones as stored.
  view.block_voxels(view.find_block(1, 0, 0))[voxel_in_block(9, 2, 3)] = Voxel{-5, 7};
  EXPECT_EQ(view.voxel(9, 2, 3).tsdf, -5);
  EXPECT_EQ(view.voxel(9, 2, 3).weight, 7);
  EXPECT_EQ(view.voxel(-1, 2, 3).weight, 0);
  EXPECT_EQ(view.voxel(-1, 2, 3).tsdf, static_cast<int16_t>(kTsdfScale));
  map.clear();
  EXPECT_EQ(map.block_count(), 0);
  EXPECT_EQ(map.view().find_block(1, 0, 0), -1);
  EXPECT_EQ(map.view().voxel(9, 2, 3).weight, 0);
}

TEST(HostBlockMap, VoxelCoordinatesMapToBlocksByFloorDivision) {
  EXPECT_EQ(block_of_voxel(0), 0);
  EXPECT_EQ(block_of_voxel(7), 0);
  EXPECT_EQ(block_of_voxel(8), 1);
  EXPECT_EQ(block_of_voxel(-1), -1);
  EXPECT_EQ(block_of_voxel(-8), -1);
  EXPECT_EQ(block_of_voxel(-9), -2);
  EXPECT_EQ(voxel_in_block(-1, 0, 0), 7);
  EXPECT_EQ(voxel_in_block(-8, -1, 9), 0 + 7 * 8 + 1 * 64);
}

TEST(HostBlockMap, BudgetGivesCapacity) {
  EXPECT_EQ(block_capacity_for_budget(0), 1u);
  EXPECT_EQ(block_capacity_for_budget(kBytesPerBlock * 100 + 5), 100u);
}

}  // namespace
}  // namespace kfx
