#include "map/block_swap.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace kfx {

namespace {

/// Appends block i of `from` (key and voxels) to `to`.
void append_block(BlockMapContents& to, const BlockMapContents& from, size_t i) {
  to.keys.push_back(from.keys[i]);
  to.voxels.insert(to.voxels.end(), from.voxels.begin() + i * kBlockVoxels,
                   from.voxels.begin() + (i + 1) * kBlockVoxels);
}

/// Empties `c` (keeping its arrays' capacity, so a pass after the first allocates nothing new)
/// and gives it `like`'s voxel size.
void clear_like(BlockMapContents& c, const BlockMapContents& like) {
  c.keys.clear();
  c.voxels.clear();
  c.colours.clear();
  c.grid_res = like.grid_res;
  c.grid_size_m = like.grid_size_m;
}

/// Appends block i's colours of `from` to `to`, or none yet when `from` carries none.
void append_colours(BlockMapContents& to, const BlockMapContents& from, size_t i) {
  if (from.colours.empty()) {
    to.colours.resize(to.colours.size() + kBlockVoxels, ColourVoxel{0, 0, 0, 0});
  } else {
    to.colours.insert(to.colours.end(), from.colours.begin() + i * kBlockVoxels,
                      from.colours.begin() + (i + 1) * kBlockVoxels);
  }
}

}  // namespace

Voxel merge_voxel(Voxel a, Voxel b, int tsdf_weight_cap) {
  if (b.weight <= 0) return a;
  if (a.weight <= 0) return b;
  const double wa = a.weight, wb = b.weight;
  const double tsdf = (wa * a.tsdf + wb * b.tsdf) / (wa + wb);
  Voxel m;
  m.tsdf = static_cast<int16_t>(std::lround(tsdf));
  m.weight = static_cast<int16_t>(std::min(wa + wb, static_cast<double>(tsdf_weight_cap)));
  return m;
}

ColourVoxel merge_colour(ColourVoxel a, ColourVoxel b, int colour_weight_cap) {
  if (b.weight == 0) return a;
  if (a.weight == 0) return b;
  const double wa = a.weight, wb = b.weight, inv = 1.0 / (wa + wb);
  auto mean = [&](uint16_t x, uint16_t y) {
    return static_cast<uint16_t>(std::lround((wa * x + wb * y) * inv));
  };
  ColourVoxel m;
  m.r = mean(a.r, b.r);
  m.g = mean(a.g, b.g);
  m.b = mean(a.b, b.b);
  m.weight = static_cast<uint16_t>(std::min(wa + wb, static_cast<double>(colour_weight_cap)));
  return m;
}

int merge_contents_into(const BlockMapContents& a, const BlockMapContents& b,
                        const VoxelWeightCaps& caps, BlockMapContents& out) {
  clear_like(out, a.keys.empty() ? b : a);
  int merged = 0;
  const bool colour = !a.colours.empty() || !b.colours.empty();
  out.keys.reserve(a.keys.size() + b.keys.size());
  out.voxels.reserve((a.keys.size() + b.keys.size()) * kBlockVoxels);
  size_t i = 0, j = 0;
  while (i < a.keys.size() || j < b.keys.size()) {
    const bool take_a = j == b.keys.size() || (i < a.keys.size() && a.keys[i] < b.keys[j]);
    const bool take_b = i == a.keys.size() || (j < b.keys.size() && b.keys[j] < a.keys[i]);
    if (take_a) {
      append_block(out, a, i);
      if (colour) append_colours(out, a, i);
      ++i;
    } else if (take_b) {
      append_block(out, b, j);
      if (colour) append_colours(out, b, j);
      ++j;
    } else {  // the same key on both sides
      out.keys.push_back(a.keys[i]);
      for (int v = 0; v < kBlockVoxels; ++v) {
        out.voxels.push_back(
            merge_voxel(a.voxels[i * kBlockVoxels + v], b.voxels[j * kBlockVoxels + v], caps.tsdf));
      }
      if (colour) {
        const ColourVoxel none{0, 0, 0, 0};
        for (int v = 0; v < kBlockVoxels; ++v) {
          const ColourVoxel ca = a.colours.empty() ? none : a.colours[i * kBlockVoxels + v];
          const ColourVoxel cb = b.colours.empty() ? none : b.colours[j * kBlockVoxels + v];
          out.colours.push_back(merge_colour(ca, cb, caps.colour));
        }
      }
      ++i;
      ++j;
      ++merged;
    }
  }
  return merged;
}

BlockMapContents merge_contents(const BlockMapContents& a, const BlockMapContents& b,
                                const VoxelWeightCaps& caps) {
  BlockMapContents out;
  merge_contents_into(a, b, caps, out);
  return out;
}

float block_centre_distance_m(uint64_t key, float voxel_m, Vec3f point_m) {
  const Vec3i c = unpack_block_key(key);
  const float half = 0.5f * kBlockSide;
  const Vec3f centre{(c.x * kBlockSide + half) * voxel_m, (c.y * kBlockSide + half) * voxel_m,
                     (c.z * kBlockSide + half) * voxel_m};
  return length(centre - point_m);
}

namespace {

/// Splits `map` into the blocks `keep` selects (`first`) and the rest (`second`), both in key
/// order; neither may be `map`.
template <class Keep>
void split_into(const BlockMapContents& map, Keep&& keep, BlockMapContents& first,
                BlockMapContents& second) {
  clear_like(first, map);
  clear_like(second, map);
  for (size_t i = 0; i < map.keys.size(); ++i) {
    BlockMapContents& to = keep(i) ? first : second;
    append_block(to, map, i);
    if (!map.colours.empty()) append_colours(to, map, i);
  }
}

}  // namespace

SwapPassResult BlockSwapStore::pass(BlockMapContents& active, Vec3f camera_m, float distance_m,
                                    int max_active_blocks) {
  SwapPassResult result;
  const float voxel_m = active.grid_size_m / active.grid_res;
  auto near = [&](const BlockMapContents& map, size_t i) {
    return block_centre_distance_m(map.keys[i], voxel_m, camera_m) <= distance_m;
  };
  // Nothing to move (the keys alone tell): the active map stays as it is, uncopied.
  bool moves = false;
  for (size_t i = 0; !moves && i < active.keys.size(); ++i) moves = !near(active, i);
  for (size_t i = 0; !moves && i < store_.keys.size(); ++i) moves = near(store_, i);
  if (!moves) return result;
  split_into(
      active, [&](size_t i) { return near(active, i); }, kept_, out_);
  result.swapped_out = static_cast<int>(out_.keys.size());
  result.merged += merge_contents_into(store_, out_, caps_, scratch_);
  std::swap(store_, scratch_);

  // The store's blocks within the distance, nearest first (ties by key), as many as fit.
  std::vector<std::pair<float, uint64_t>> back;
  for (size_t i = 0; i < store_.keys.size(); ++i) {
    const float d = block_centre_distance_m(store_.keys[i], voxel_m, camera_m);
    if (d <= distance_m) back.emplace_back(d, store_.keys[i]);
  }
  const size_t room =
      static_cast<size_t>(std::max(0, max_active_blocks - static_cast<int>(kept_.keys.size())));
  if (back.size() > room) {
    std::nth_element(back.begin(), back.begin() + room, back.end());
    back.resize(room);
  }
  std::vector<uint64_t> back_keys;
  back_keys.reserve(back.size());
  for (const auto& b : back) back_keys.push_back(b.second);
  std::sort(back_keys.begin(), back_keys.end());
  split_into(
      store_,
      [&](size_t i) {
        return std::binary_search(back_keys.begin(), back_keys.end(), store_.keys[i]);
      },
      returning_, scratch_);
  std::swap(store_, scratch_);
  result.swapped_in = static_cast<int>(returning_.keys.size());
  result.merged += merge_contents_into(kept_, returning_, caps_, active);
  return result;
}

BlockMapContents BlockSwapStore::with_store(const BlockMapContents& active) const {
  if (store_.keys.empty()) return active;
  return merge_contents(active, store_, caps_);
}

}  // namespace kfx
