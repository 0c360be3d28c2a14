#pragma once
/// Marching cubes over a block map in host memory (kernels/marching_cubes_blocks.hpp's bodies,
/// OpenMP over blocks). The CPU backend meshes its live map with it; the CUDA backend meshes a
/// host copy of its blocks with it, so both give the same bytes for the same map.

#include <vector>

#include "core/mesh.hpp"
#include "map/block_map.hpp"
#include "map/host_block_map.hpp"

namespace kfx {

/// The mesh of `map`'s blocks (block indices 0 .. map.block_count − 1, in host memory), written
/// into `vertices` and `triangles`, which only grow (no allocation once large enough); the
/// returned view points into them. Throws kfx::Error when the mesh has more vertices or
/// triangles than PLY's int indices address.
MeshView extract_block_map_mesh(const BlockMapView& map, std::vector<MeshVertex>& vertices,
                                std::vector<MeshTriangle>& triangles);

/// The same for a map's contents (a host copy of a device map, or a map with blocks swapped
/// out): loaded into a host map of its own size first.
MeshView extract_block_map_mesh(const BlockMapContents& contents, std::vector<MeshVertex>& vertices,
                                std::vector<MeshTriangle>& triangles);

}  // namespace kfx
