#pragma once
/// Marching cubes over a block map (kernels/marching_cubes.hpp's per-voxel bodies, which read
/// the map through a BlockMapReader), one block per call, in the dense passes' three steps:
///   0. mc_map_block_sign_bits / mc_map_block_active: a block is active when it and its +1
///      neighbours hold both a weighted voxel inside and one outside (unallocated neighbours
///      hold neither); only active blocks own vertices or start meshed cells;
///   1. mc_count_block: each voxel's first vertex within its block (an exclusive prefix of its
///      owned vertex counts in voxel order), the block's vertex and triangle counts;
///   2. mc_write_block, after the backend turned the block counts into offsets: vertices at
///      their voxel's index, triangles at their block's offset.
/// Active blocks are numbered in increasing key order (`active_blocks`), so the mesh depends on
/// the map's contents alone, not on the order its blocks were allocated in: a reloaded map
/// meshes to the same bytes.

#include <cstdint>

#include "core/mesh.hpp"
#include "kernels/marching_cubes.hpp"
#include "map/block_map.hpp"

namespace kfx {

/// Arguments of the block-map marching-cubes passes.
struct BlockMeshArgs {
  BlockMapView map;      ///< read only
  const McTable* table;  ///< kMcTable (a device copy on the GPU)
  /// Block indices of the active blocks, in increasing key order; slot s meshes block
  /// active_blocks[s].
  const int32_t* active_blocks;
  /// By block index: its slot in active_blocks, −1 when not active.
  const int32_t* active_slot;
  /// kBlockVoxels per slot: pass 1 writes each voxel's first vertex within the block.
  uint32_t* voxel_first_vertex;
  /// One per slot + 1: pass 1 writes the block's vertex count, pass 2 reads the exclusive
  /// prefix sum (the entry after the last slot: the total).
  uint32_t* block_vertex_offset;
  /// The same for triangles.
  uint32_t* block_triangle_offset;
  MeshVertex* vertices;     ///< pass 2 output
  MeshTriangle* triangles;  ///< pass 2 output
};

/// OR of mc_voxel_sign_bits over block index b's voxels.
KFX_HD inline uint8_t mc_map_block_sign_bits(const BlockMapView& map, int32_t b) {
  const Voxel* voxels = map.block_voxels(b);
  uint8_t bits = 0;
  for (int i = 0; i < kBlockVoxels; ++i) bits |= mc_voxel_sign_bits(voxels[i]);
  return bits;
}

/// 1 when block index b may own a vertex or start a meshed cell (mc_brick_active's rule over
/// the block and its +1 neighbours); `sign_bits` holds mc_map_block_sign_bits by block index.
KFX_HD inline uint8_t mc_map_block_active(const BlockMapView& map, const uint8_t* sign_bits,
                                          int32_t b) {
  const Vec3i c = map.block_coords(b);
  uint8_t bits = 0;
  for (int k = 0; k < 8; ++k) {
    const int32_t n =
        k == 0 ? b : map.find_block(c.x + (k & 1), c.y + ((k >> 1) & 1), c.z + (k >> 2));
    if (n >= 0) bits |= sign_bits[n];
  }
  return bits == 3 ? 1 : 0;
}

/// Voxel coordinates of voxel i (voxel_in_block order) of the block at coordinates c.
KFX_HD inline Vec3i mc_block_voxel(Vec3i c, int i) {
  return {c.x * kBlockSide + (i & (kBlockSide - 1)),
          c.y * kBlockSide + ((i >> kBrickShift) & (kBlockSide - 1)),
          c.z * kBlockSide + (i >> (2 * kBrickShift))};
}

/// Pass 1 for slot s: per-voxel first vertices within the block, the block's vertex and
/// triangle counts.
KFX_HD inline void mc_count_block(int s, const BlockMeshArgs& a) {
  const int32_t b = a.active_blocks[s];
  const Vec3i c = a.map.block_coords(b);
  const Voxel* voxels = a.map.block_voxels(b);
  BlockMapReader reader = map_reader(a.map);
  uint32_t* first = a.voxel_first_vertex + static_cast<long long>(s) * kBlockVoxels;
  uint32_t vertices = 0, triangles = 0;
  for (int i = 0; i < kBlockVoxels; ++i) {
    first[i] = vertices;
    if (voxels[i].weight <= 0) continue;  // owns nothing, starts no valid cell
    const Vec3i v = mc_block_voxel(c, i);
    vertices += mc_owned_vertex_count(reader, v.x, v.y, v.z);
    triangles += a.table->triangle_count[mc_cell_case(reader, v.x, v.y, v.z)];
  }
  a.block_vertex_offset[s] = vertices;
  a.block_triangle_offset[s] = triangles;
}

/// Index of the vertex on the edge from voxel (x, y, z) along `axis` (pass 2).
KFX_HD inline int32_t mc_map_vertex_index(const BlockMeshArgs& a, BlockMapReader& reader, int x,
                                          int y, int z, int axis) {
  const int32_t b = a.map.block_of(x, y, z);
  const int32_t s = a.active_slot[b];  // a voxel owning a vertex lies in an active block
  const int i = voxel_in_block(x, y, z);
  uint32_t index =
      a.block_vertex_offset[s] + a.voxel_first_vertex[static_cast<long long>(s) * kBlockVoxels + i];
  for (int lower = 0; lower < axis; ++lower) index += mc_edge_has_vertex(reader, x, y, z, lower);
  return static_cast<int32_t>(index);
}

/// Pass 2 for slot s: the vertices its voxels own and the triangles of its cells.
KFX_HD inline void mc_write_block(int s, const BlockMeshArgs& a) {
  const int32_t b = a.active_blocks[s];
  const Vec3i c = a.map.block_coords(b);
  const Voxel* voxels = a.map.block_voxels(b);
  BlockMapReader reader = map_reader(a.map);
  uint32_t vertex = a.block_vertex_offset[s];
  uint32_t triangle = a.block_triangle_offset[s];
  for (int i = 0; i < kBlockVoxels; ++i) {
    if (voxels[i].weight <= 0) continue;
    const Vec3i v = mc_block_voxel(c, i);
    for (int axis = 0; axis < 3; ++axis) {
      if (mc_edge_has_vertex(reader, v.x, v.y, v.z, axis))
        a.vertices[vertex++] = mc_edge_vertex(reader, v.x, v.y, v.z, axis);
    }
    const int pattern = mc_cell_case(reader, v.x, v.y, v.z);
    const int count = a.table->triangle_count[pattern];
    for (int t = 0; t < count; ++t) {
      MeshTriangle out;
      for (int k = 0; k < 3; ++k) {
        const int edge = a.table->edges[pattern][3 * t + k];
        const int corner = mc_edge_lower_corner(edge);
        out.v[k] = mc_map_vertex_index(a, reader, v.x + (corner & 1), v.y + ((corner >> 1) & 1),
                                       v.z + ((corner >> 2) & 1), mc_edge_axis(edge));
      }
      a.triangles[triangle++] = out;
    }
  }
}

}  // namespace kfx
