#pragma once
/// The map a backend keeps: one object that owns its memory, knows where it lives (host or
/// device: `Memory`, map/map_memory.hpp) and which kind it is (the dense cube or the block
/// map). A stage does not ask the kind: it hands the map a generic callable (visit), which the
/// map calls with its own storage, and the stage's overloads for each kind (or one generic
/// body over the storage's view(): the kernel bodies are templates on the map view) do the rest.
/// The branch on the kind is taken once per stage call, on the host; inside a kernel every
/// access is the view's, inlined.
///
/// `Blocks` is the block map of that location (HostBlockMap on the host, the CUDA backend's
/// DeviceBlockMap on the device): what the two decide differently (allocation on one thread or
/// thousands) stays theirs; their storage, view and insertion are shared
/// (map/block_map_store.hpp). Nothing in a map refers to its backend, so a backend holds several
/// (map/map_set.hpp: submaps, or a map being rebuilt beside the one tracked against).

#include <utility>

#include "core/platform.hpp"
#include "map/dense_cube_store.hpp"
#include "map/map_memory.hpp"

namespace kfx {

/// Which kind of map (setting `volume`).
enum class MapKind : int {
  kDense = 0,   ///< one cube of res³ voxels (SLAMBench's)
  kBlocks = 1,  ///< 8³ voxel blocks allocated where depth lands, found through a hash table
};

template <class Memory, class Blocks>
class VoxelMap {
 public:
  using Cube = DenseCubeStore<Memory>;

  VoxelMap() = default;
  /// A dense cube.
  explicit VoxelMap(Cube cube) : kind_(MapKind::kDense), cube_(std::move(cube)) {}
  /// A block map.
  explicit VoxelMap(Blocks blocks) : kind_(MapKind::kBlocks), blocks_(std::move(blocks)) {}

  MapKind kind() const { return kind_; }
  static constexpr MemoryLocation location() { return Memory::kLocation; }

  /// Calls f with the map's storage (Cube& or Blocks&) and returns what it returns (the same
  /// type for both).
  template <class F>
  decltype(auto) visit(F&& f) {
    if (kind_ == MapKind::kBlocks) return f(blocks_);
    return f(cube_);
  }

  /// Empties the map: every voxel reads as empty.
  void clear(const Memory& memory) {
    visit([&](auto& storage) { storage.clear(memory); });
  }

  /// The dense cube; throws kfx::Error naming `what` (the call that needs it) on a block map.
  Cube& cube(const char* what) {
    KFX_CHECK(kind_ == MapKind::kDense,
              what << ": volume=blocks: the map is a block map, not the dense cube");
    return cube_;
  }
  /// The block map; throws kfx::Error naming `what` on the dense cube.
  Blocks& blocks(const char* what) {
    KFX_CHECK(kind_ == MapKind::kBlocks,
              what << ": volume=dense: the map is the dense cube, not a block map");
    return blocks_;
  }

 private:
  MapKind kind_ = MapKind::kDense;
  Cube cube_;      ///< unallocated for a block map
  Blocks blocks_;  ///< unallocated for the dense cube
};

/// The dense colour field a render reads beside `map` (the cube's; a block map's colours are
/// in its blocks, so none).
template <class Memory>
ColourVolumeView dense_colour_view(const DenseCubeStore<Memory>& cube) {
  return cube.colour_view();
}
template <class Blocks>
ColourVolumeView dense_colour_view(const Blocks&) {
  return ColourVolumeView{};
}

}  // namespace kfx
