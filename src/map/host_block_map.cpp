/// The host block map: storage, clearing and deterministic allocation.

#include "map/host_block_map.hpp"

#include <algorithm>
#include <numeric>

namespace kfx {

uint32_t block_capacity_for_budget(uint64_t budget_bytes, bool colour) {
  const uint64_t blocks = budget_bytes / block_bytes(colour);
  // The hash's slot count (a power of two ≥ 2 × capacity) must fit 32 bits.
  constexpr uint64_t kMaxBlocks = uint64_t{1} << 30;
  return static_cast<uint32_t>(std::max<uint64_t>(1, std::min(blocks, kMaxBlocks)));
}

void sort_blocks_by_key(BlockMapContents& c) {
  const size_t n = c.keys.size();
  KFX_CHECK(c.voxels.size() == n * kBlockVoxels &&
                (c.colours.empty() || c.colours.size() == c.voxels.size()),
            "a map of " << n << " blocks with " << c.voxels.size() << " voxels and "
                        << c.colours.size() << " colours");
  std::vector<size_t> order(n);  // the block that belongs at position i
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(), [&](size_t l, size_t r) { return c.keys[l] < c.keys[r]; });
  const bool colour = !c.colours.empty();
  std::vector<Voxel> held_voxels(kBlockVoxels);
  std::vector<ColourVoxel> held_colours(colour ? kBlockVoxels : 0);
  const auto move_block = [&](size_t from, size_t to) {
    c.keys[to] = c.keys[from];
    std::copy_n(c.voxels.begin() + from * kBlockVoxels, kBlockVoxels,
                c.voxels.begin() + to * kBlockVoxels);
    if (colour) {
      std::copy_n(c.colours.begin() + from * kBlockVoxels, kBlockVoxels,
                  c.colours.begin() + to * kBlockVoxels);
    }
  };
  // Each cycle of the permutation: hold its first block, pull each block into the place it
  // leaves, and put the held one last.
  std::vector<bool> placed(n, false);
  for (size_t start = 0; start < n; ++start) {
    if (placed[start] || order[start] == start) continue;
    const uint64_t held_key = c.keys[start];
    std::copy_n(c.voxels.begin() + start * kBlockVoxels, kBlockVoxels, held_voxels.begin());
    if (colour) {
      std::copy_n(c.colours.begin() + start * kBlockVoxels, kBlockVoxels, held_colours.begin());
    }
    size_t to = start;
    while (order[to] != start) {
      move_block(order[to], to);
      placed[to] = true;
      to = order[to];
    }
    c.keys[to] = held_key;
    std::copy(held_voxels.begin(), held_voxels.end(), c.voxels.begin() + to * kBlockVoxels);
    if (colour) {
      std::copy(held_colours.begin(), held_colours.end(), c.colours.begin() + to * kBlockVoxels);
    }
    placed[to] = true;
  }
}

HostBlockMap::HostBlockMap(uint32_t block_capacity, int grid_res, float grid_size_m, bool colour)
    : store_(block_capacity, grid_res, grid_size_m, colour, /*tables=*/false) {
  KFX_CHECK(block_capacity >= 1, "a block map needs room for at least one block");
  clear();
}

void HostBlockMap::clear() {
  store_.clear(HostMemory{});
  coarse_count_ = 0;
  block_count_ = 0;
}

BlockAllocation HostBlockMap::allocate(std::vector<uint64_t>& candidates) {
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  BlockAllocation result;
  const BlockMapView map = view();
  for (const uint64_t key : candidates) {
    if (map.hash.find(key) >= 0) continue;
    if (block_count_ >= static_cast<int>(block_capacity())) {
      ++result.dropped;
      continue;
    }
    const size_t first = static_cast<size_t>(block_count_) * kBlockVoxels;
    std::fill_n(store_.voxels.data() + first, kBlockVoxels, empty_voxel());
    if (has_colour())
      std::fill_n(store_.colours.data() + first, kBlockVoxels, ColourVoxel{0, 0, 0, 0});
    insert_new_block(key);
    ++result.allocated;
  }
  return result;
}

void HostBlockMap::add_block(uint64_t key, const Voxel* voxels, const ColourVoxel* colours) {
  KFX_CHECK(block_count_ < static_cast<int>(block_capacity()),
            "the map holds " << block_capacity() << " blocks; one more does not fit");
  const size_t first = static_cast<size_t>(insert_loaded_block(key)) * kBlockVoxels;
  std::copy(voxels, voxels + kBlockVoxels, store_.voxels.data() + first);
  if (has_colour() && colours) {
    std::copy(colours, colours + kBlockVoxels, store_.colours.data() + first);
  } else if (has_colour()) {
    std::fill_n(store_.colours.data() + first, kBlockVoxels, ColourVoxel{0, 0, 0, 0});
  }
}

int HostBlockMap::insert_loaded_block(uint64_t key) {
  const Vec3i c = unpack_block_key(key);
  KFX_CHECK(view().hash.find(key) < 0,
            "block (" << c.x << ", " << c.y << ", " << c.z << ") is in the map twice");
  const int b = block_count_;
  insert_new_block(key);
  store_.block_touched.data()[b] = 1;  // unknown contents: never skipped
  store_.coarse_touched.data()[store_.block_coarse.data()[b]] = 1;
  return b;
}

void HostBlockMap::insert_new_block(uint64_t key) {
  const BlockMapView map = view();
  KFX_CHECK(insert_block_index(map, key, block_count_, &coarse_count_) == BlockInsert::kInserted,
            "block hash refused a new key below capacity");
  link_block_to_coarse(map, block_count_);
  ++block_count_;
}

void HostBlockMap::contents_into(BlockMapContents& c) const {
  const size_t n = static_cast<size_t>(block_count_);
  c.grid_res = grid_res();
  c.grid_size_m = grid_size_m();
  c.keys.assign(store_.block_keys.data(), store_.block_keys.data() + n);
  c.voxels.assign(store_.voxels.data(), store_.voxels.data() + n * kBlockVoxels);
  if (has_colour()) {
    c.colours.assign(store_.colours.data(), store_.colours.data() + n * kBlockVoxels);
  } else {
    c.colours.clear();
  }
  sort_blocks_by_key(c);
}

void HostBlockMap::load(const BlockMapContents& c) {
  load_index(c);
  std::copy(c.voxels.begin(), c.voxels.end(), store_.voxels.data());
  if (!has_colour()) return;
  if (c.colours.empty()) {
    std::fill_n(store_.colours.data(), c.voxels.size(), ColourVoxel{0, 0, 0, 0});
  } else {
    std::copy(c.colours.begin(), c.colours.end(), store_.colours.data());
  }
}

void HostBlockMap::load_index(const BlockMapContents& c) {
  KFX_CHECK(c.grid_res == grid_res() && c.grid_size_m == grid_size_m(),
            "a map of voxel size " << c.grid_size_m / c.grid_res
                                   << " m cannot be loaded into one of "
                                   << grid_size_m() / grid_res() << " m");
  KFX_CHECK(c.voxels.size() == c.keys.size() * kBlockVoxels,
            "a map of " << c.keys.size() << " blocks with " << c.voxels.size() << " voxels");
  KFX_CHECK(c.colours.empty() || c.colours.size() == c.voxels.size(),
            "a map of " << c.keys.size() << " blocks with " << c.colours.size() << " colours");
  KFX_CHECK(c.keys.size() <= block_capacity(), "a map of " << c.keys.size()
                                                           << " blocks does not fit one of "
                                                           << block_capacity() << " blocks");
  clear();
  for (const uint64_t key : c.keys) insert_loaded_block(key);
}

BlockMapView HostBlockMap::view_of_contents(const BlockMapContents& c) {
  KFX_CHECK(c.keys.size() == static_cast<size_t>(block_count_) &&
                (c.keys.empty() || c.keys.front() == store_.block_keys.data()[0]),
            "view_of_contents: the index was not loaded from these contents");
  BlockMapView v = view();
  // The view type serves writers too; this one is only read.
  v.voxels = const_cast<Voxel*>(c.voxels.data());
  v.colours =
      has_colour() && !c.colours.empty() ? const_cast<ColourVoxel*>(c.colours.data()) : nullptr;
  return v;
}

}  // namespace kfx
