#pragma once
/// Reading a block map's contents (a host copy of the GPU's blocks, a loaded file, the active
/// map with its swapped-out blocks) in place: a host map that holds only the contents' index,
/// through which HostBlockMap::view_of_contents reads the contents' own voxels and colours, so
/// the host needs no second copy of the map. The mesh, the renders from a pose and the colour
/// field all read a map's contents this way.

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "map/host_block_map.hpp"

namespace kfx {

/// A host map sized to `contents` (at least one block) holding the index of its blocks
/// (HostBlockMap::load_index; block i of the contents at index i); throws kfx::Error as
/// load_index does.
inline HostBlockMap index_of_contents(const BlockMapContents& contents) {
  HostBlockMap index(static_cast<uint32_t>(std::max<size_t>(1, contents.keys.size())),
                     contents.grid_res, contents.grid_size_m, !contents.colours.empty());
  index.load_index(contents);
  return index;
}

}  // namespace kfx
