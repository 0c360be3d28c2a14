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
    : hash_keys_(block_hash_slot_count(block_capacity), kEmptyBlockKey),
      hash_values_(hash_keys_.size(), -1),
      voxels_(new Voxel[static_cast<size_t>(block_capacity) * kBlockVoxels]),
      colours_(colour ? new ColourVoxel[static_cast<size_t>(block_capacity) * kBlockVoxels]
                      : nullptr),
      block_keys_(block_capacity, kEmptyBlockKey),
      block_touched_(block_capacity, 0),
      block_coarse_(block_capacity, -1),
      coarse_keys_(block_hash_slot_count(block_capacity), kEmptyBlockKey),
      coarse_values_(coarse_keys_.size(), -1),
      coarse_touched_(block_capacity, 0),
      grid_res_(grid_res),
      grid_size_m_(grid_size_m) {
  KFX_CHECK(block_capacity >= 1, "a block map needs room for at least one block");
}

void HostBlockMap::clear() {
  std::fill(hash_keys_.begin(), hash_keys_.end(), kEmptyBlockKey);
  std::fill(hash_values_.begin(), hash_values_.end(), -1);
  std::fill(block_keys_.begin(), block_keys_.end(), kEmptyBlockKey);
  std::fill(block_touched_.begin(), block_touched_.end(), 0);
  std::fill(block_coarse_.begin(), block_coarse_.end(), -1);
  std::fill(coarse_keys_.begin(), coarse_keys_.end(), kEmptyBlockKey);
  std::fill(coarse_values_.begin(), coarse_values_.end(), -1);
  std::fill(coarse_touched_.begin(), coarse_touched_.end(), 0);
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
    std::fill(voxels_.get() + first, voxels_.get() + first + kBlockVoxels, empty_voxel());
    if (colours_) std::fill_n(colours_.get() + first, kBlockVoxels, ColourVoxel{0, 0, 0, 0});
    insert_new_block(key);
    ++result.allocated;
  }
  return result;
}

void HostBlockMap::add_block(uint64_t key, const Voxel* voxels, const ColourVoxel* colours) {
  KFX_CHECK(block_count_ < static_cast<int>(block_capacity()),
            "the map holds " << block_capacity() << " blocks; one more does not fit");
  const size_t first = static_cast<size_t>(insert_loaded_block(key)) * kBlockVoxels;
  std::copy(voxels, voxels + kBlockVoxels, voxels_.get() + first);
  if (colours_ && colours) {
    std::copy(colours, colours + kBlockVoxels, colours_.get() + first);
  } else if (colours_) {
    std::fill_n(colours_.get() + first, kBlockVoxels, ColourVoxel{0, 0, 0, 0});
  }
}

int HostBlockMap::insert_loaded_block(uint64_t key) {
  const Vec3i c = unpack_block_key(key);
  KFX_CHECK(view().hash.find(key) < 0,
            "block (" << c.x << ", " << c.y << ", " << c.z << ") is in the map twice");
  const int b = block_count_;
  insert_new_block(key);
  block_touched_[b] = 1;  // unknown contents: never skipped
  coarse_touched_[block_coarse_[b]] = 1;
  return b;
}

void HostBlockMap::insert_new_block(uint64_t key) {
  const BlockMapView map = view();
  const BlockInsert outcome = map.hash.insert(key, block_count_);
  KFX_CHECK(outcome == BlockInsert::kInserted, "block hash refused a new key below capacity");
  const Vec3i c = unpack_block_key(key);
  const uint64_t coarse =
      pack_block_key(c.x >> kCoarseShift, c.y >> kCoarseShift, c.z >> kCoarseShift);
  int32_t cell = map.coarse_hash.find(coarse);
  if (cell < 0) {
    cell = coarse_count_++;
    KFX_CHECK(map.coarse_hash.insert(coarse, cell) == BlockInsert::kInserted,
              "coarse hash refused a new key below capacity");
  }
  block_coarse_[block_count_] = cell;
  block_keys_[block_count_++] = key;
}

void HostBlockMap::contents_into(BlockMapContents& c) const {
  const size_t n = static_cast<size_t>(block_count_);
  c.grid_res = grid_res_;
  c.grid_size_m = grid_size_m_;
  c.keys.assign(block_keys_.begin(), block_keys_.begin() + static_cast<std::ptrdiff_t>(n));
  c.voxels.assign(voxels_.get(), voxels_.get() + n * kBlockVoxels);
  if (colours_) {
    c.colours.assign(colours_.get(), colours_.get() + n * kBlockVoxels);
  } else {
    c.colours.clear();
  }
  sort_blocks_by_key(c);
}

void HostBlockMap::load(const BlockMapContents& c) {
  load_index(c);
  std::copy(c.voxels.begin(), c.voxels.end(), voxels_.get());
  if (!colours_) return;
  if (c.colours.empty()) {
    std::fill_n(colours_.get(), c.voxels.size(), ColourVoxel{0, 0, 0, 0});
  } else {
    std::copy(c.colours.begin(), c.colours.end(), colours_.get());
  }
}

void HostBlockMap::load_index(const BlockMapContents& c) {
  KFX_CHECK(c.grid_res == grid_res_ && c.grid_size_m == grid_size_m_,
            "a map of voxel size " << c.grid_size_m / c.grid_res
                                   << " m cannot be loaded into one of " << grid_size_m_ / grid_res_
                                   << " m");
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

BlockMapView HostBlockMap::view() {
  BlockMapView v;
  v.hash = BlockHashView{hash_keys_.data(), hash_values_.data(),
                         static_cast<uint32_t>(hash_keys_.size() - 1)};
  v.voxels = voxels_.get();
  v.block_keys = block_keys_.data();
  v.block_touched = block_touched_.data();
  v.coarse_hash = BlockHashView{coarse_keys_.data(), coarse_values_.data(),
                                static_cast<uint32_t>(coarse_keys_.size() - 1)};
  v.coarse_touched = coarse_touched_.data();
  v.block_coarse = block_coarse_.data();
  v.block_capacity = static_cast<int>(block_capacity());
  v.block_count = block_count_;
  v.grid_res = grid_res_;
  v.grid_size_m = grid_size_m_;
  v.colours = colours_.get();
  return v;
}

BlockMapView HostBlockMap::view_of_contents(const BlockMapContents& c) {
  KFX_CHECK(c.keys.size() == static_cast<size_t>(block_count_) &&
                (c.keys.empty() || c.keys.front() == block_keys_.front()),
            "view_of_contents: the index was not loaded from these contents");
  BlockMapView v = view();
  // The view type serves writers too; this one is only read.
  v.voxels = const_cast<Voxel*>(c.voxels.data());
  v.colours = colours_ && !c.colours.empty() ? const_cast<ColourVoxel*>(c.colours.data()) : nullptr;
  return v;
}

uint64_t HostBlockMap::reserved_bytes() const {
  return (hash_keys_.size() + coarse_keys_.size()) * (sizeof(uint64_t) + sizeof(int32_t)) +
         block_keys_.size() *
             (sizeof(Voxel) * kBlockVoxels + sizeof(uint64_t) + 1 + sizeof(int32_t) + 1 +
              (colours_ ? sizeof(ColourVoxel) * kBlockVoxels : 0));
}

}  // namespace kfx
