/// The direct-mapped block table (map/block_table.hpp): it answers as the hash would or defers
/// to it, only where two or more blocks share an entry, whatever order the blocks came in; and
/// a block map that carries one finds the same blocks as one that does not.

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <tuple>
#include <vector>

#include "map/block_map.hpp"
#include "map/block_table.hpp"
#include "map/host_block_map.hpp"

namespace kfx {
namespace {

using Coords = std::tuple<int, int, int>;

/// A table in a vector, every entry empty.
struct Table {
  Table() : entries(static_cast<size_t>(kBlockTableEntries)) { clear(); }
  void clear() {
    std::fill(
        entries.begin(), entries.end(),
        BlockTableEntry{kBlockTableEmpty, kBlockTableEmpty, kBlockTableEmpty, kBlockTableEmpty});
  }
  BlockTableView view() { return BlockTableView{entries.data()}; }
  std::vector<BlockTableEntry> entries;
};

/// Blocks near the origin, blocks a table side away (sharing entries with them) and blocks far
/// out and negative, with their indices.
std::map<Coords, int32_t> some_blocks(std::mt19937& rng) {
  std::map<Coords, int32_t> blocks;
  std::uniform_int_distribution<int> near(-20, 20), far(-3000, 3000);
  const int side = kBlockTableSide;
  while (blocks.size() < 6000) {
    const int x = near(rng), y = near(rng), z = near(rng);
    blocks.emplace(Coords{x, y, z}, 0);
    if (blocks.size() % 5 == 0) blocks.emplace(Coords{x + side, y, z - 2 * side}, 0);
    if (blocks.size() % 7 == 0) blocks.emplace(Coords{far(rng), far(rng), far(rng)}, 0);
  }
  int32_t index = 0;
  for (auto& block : blocks) block.second = index++;
  return blocks;
}

TEST(BlockTable, AnswersAsTheBlocksAreOrDefersWhereEntriesAreShared) {
  std::mt19937 rng(5);
  const std::map<Coords, int32_t> blocks = some_blocks(rng);
  std::map<int64_t, int> per_entry;
  for (const auto& [c, index] : blocks) {
    ++per_entry[BlockTableView::slot(std::get<0>(c), std::get<1>(c), std::get<2>(c))];
  }
  Table table;
  const BlockTableView view = table.view();
  for (const auto& [c, index] : blocks)
    view.insert(std::get<0>(c), std::get<1>(c), std::get<2>(c), index);

  int deferred = 0, answered = 0;
  std::uniform_int_distribution<int> probe(-30, 30);
  std::vector<Coords> queries;
  for (const auto& block : blocks) queries.push_back(block.first);
  for (int i = 0; i < 20000; ++i) {
    queries.push_back(Coords{probe(rng), probe(rng), probe(rng) - kBlockTableSide});
  }
  for (const Coords& c : queries) {
    const auto [x, y, z] = c;
    const int32_t got = view.find(x, y, z);
    const auto it = per_entry.find(BlockTableView::slot(x, y, z));
    const int sharing = it == per_entry.end() ? 0 : it->second;
    if (sharing >= 2) {
      EXPECT_EQ(got, kBlockTableAskHash) << x << "," << y << "," << z;
      ++deferred;
      continue;
    }
    const auto block = blocks.find(c);
    EXPECT_EQ(got, block == blocks.end() ? -1 : block->second) << x << "," << y << "," << z;
    ++answered;
  }
  EXPECT_GT(deferred, 100) << "the blocks a side apart should share entries";
  EXPECT_GT(answered, 10000);
}

TEST(BlockTable, EndsInTheSameStateWhateverTheInsertionOrder) {
  std::mt19937 rng(9);
  const std::map<Coords, int32_t> blocks = some_blocks(rng);
  std::vector<std::pair<Coords, int32_t>> order(blocks.begin(), blocks.end());
  Table first, other;
  for (const auto& [c, index] : order) {
    first.view().insert(std::get<0>(c), std::get<1>(c), std::get<2>(c), index);
  }
  std::shuffle(order.begin(), order.end(), rng);
  for (const auto& [c, index] : order) {
    other.view().insert(std::get<0>(c), std::get<1>(c), std::get<2>(c), index);
  }
  // An entry's coordinates matter only while it holds one block.
  for (size_t i = 0; i < first.entries.size(); ++i) {
    const BlockTableEntry a = first.entries[i], b = other.entries[i];
    ASSERT_EQ(a.index, b.index) << "entry " << i;
    if (a.index >= 0) {
      ASSERT_EQ(std::make_tuple(a.bx, a.by, a.bz), std::make_tuple(b.bx, b.by, b.bz));
    }
  }
}

TEST(BlockTable, AMapWithTablesFindsWhatItsHashesFind) {
  std::mt19937 rng(13);
  const std::map<Coords, int32_t> blocks = some_blocks(rng);
  HostBlockMap map(static_cast<uint32_t>(blocks.size()), 512, 5.12f, false);
  std::vector<uint64_t> candidates;
  for (const auto& block : blocks) {
    const auto [x, y, z] = block.first;
    candidates.push_back(pack_block_key(x, y, z));
  }
  ASSERT_EQ(map.allocate(candidates).allocated, static_cast<int>(blocks.size()));
  BlockMapView with = map.view();
  ASSERT_EQ(with.table.entries, nullptr) << "the host map keeps no table";
  Table table;
  with.table = table.view();
  for (int32_t b = 0; b < with.block_count; ++b) {
    const Vec3i c = with.block_coords(b);
    with.table.insert(c.x, c.y, c.z, b);
  }
  const BlockMapView without = map.view();
  std::uniform_int_distribution<int> probe(-25, 25);
  for (const auto& block : blocks) {
    const auto [x, y, z] = block.first;
    ASSERT_GE(without.find_block(x, y, z), 0);
    EXPECT_EQ(with.find_block(x, y, z), without.find_block(x, y, z));
  }
  for (int i = 0; i < 20000; ++i) {
    const int x = probe(rng), y = probe(rng), z = probe(rng) + (i % 2) * kBlockTableSide;
    EXPECT_EQ(with.find_block(x, y, z), without.find_block(x, y, z)) << x << "," << y << "," << z;
  }
  // The coarse cells through a table of their own.
  Table coarse;
  with.coarse_table = coarse.view();
  for (uint32_t slot = 0; slot <= with.coarse_hash.slot_mask; ++slot) {
    if (with.coarse_hash.keys[slot] == kEmptyBlockKey) continue;
    const Vec3i c = unpack_block_key(with.coarse_hash.keys[slot]);
    with.coarse_table.insert(c.x, c.y, c.z, with.coarse_hash.values[slot]);
  }
  int coarse_found = 0;
  for (int i = 0; i < 20000; ++i) {
    const int x = probe(rng) / 4, y = probe(rng) / 4, z = probe(rng) / 4 + (i % 3) * 40;
    const int32_t expected = without.find_coarse(x, y, z);
    EXPECT_EQ(with.find_coarse(x, y, z), expected) << x << "," << y << "," << z;
    coarse_found += expected >= 0 ? 1 : 0;
  }
  EXPECT_GT(coarse_found, 1000);
  // Coordinates that no key packs are absent both ways.
  EXPECT_EQ(with.find_block(-kBlockCoordMin, 0, 0), -1);
  EXPECT_EQ(with.find_block(0, kBlockCoordMin - 1, 3), -1);
}

}  // namespace
}  // namespace kfx
