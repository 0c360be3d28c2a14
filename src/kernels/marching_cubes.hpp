#pragma once
/// Marching cubes over the TSDF's zero crossing (Lorensen and Cline 1987), one segment of a
/// voxel column per call (column (x, y), z slab `chunk` of kMcZChunks), in passes that both
/// backends run:
///   0. mc_voxel_sign_bits / mc_brick_active: an 8³ brick is active when it and its +1
///      neighbours hold both a weighted voxel inside (tsdf < 0) and one outside; only active
///      bricks can own a vertex or start a meshed cell, so the passes below skip the others;
///   1. mc_count_column: each voxel's count of owned vertices (0–3, one byte) and each
///      segment's triangle count; the backend turns them into exclusive prefix sums: vertices
///      per run of 8 voxels along x (mc_run_vertex_count, runs in voxel order), triangles per
///      segment (slab, then column);
///   2. mc_write_column: vertices at their voxel's offset (its run's offset plus the counts of
///      the voxels before it in the run), triangles at their segment's offset.
/// A vertex belongs to the edge it lies on, and the edge to the voxel it starts from, so
/// neighbouring cells share vertices; the output order depends on the volume alone (vertices in
/// voxel order), so the mesh is the same bytes run to run. Cells are the cubes between 8 voxel
/// centres; a cell is meshed only when all 8 corners have weight > 0. Positions are in the
/// volume frame (metres), the frame trajectory.txt uses.

#include <cstdint>

#include "core/math.hpp"
#include "core/mesh.hpp"
#include "core/volume.hpp"
#include "kernels/marching_cubes_table.hpp"

namespace kfx {

/// Arguments of the marching-cubes passes.
struct MarchingCubesArgs {
  VolumeView volume;     ///< read only
  const McTable* table;  ///< kMcTable (a device copy on the GPU)
  /// One flag per 8³ brick (mc_brick_active); 0: the passes skip the brick. Null: no skipping.
  const uint8_t* brick_active;
  /// mc_run_count() · 8 bytes: pass 1 writes each voxel's owned vertex count at
  /// mc_count_index() (bricks skipped keep whatever was there: nothing reads them).
  uint8_t* vertex_count;
  /// mc_run_count() + 1 entries: the exclusive prefix sum of mc_run_vertex_count() (entry
  /// mc_run_count() = the vertex total); pass 2 reads it.
  const uint32_t* run_vertex_offset;
  /// kMcZChunks·res² + 1 entries, by segment (mc_segment): pass 1 writes triangle counts,
  /// pass 2 reads their exclusive prefix sum.
  uint32_t* triangle_offset;
  MeshVertex* vertices;     ///< pass 2 output
  MeshTriangle* triangles;  ///< pass 2 output
};

/// Column segments per voxel column: z is cut into this many slabs so the GPU has enough
/// threads (8·res² rather than res²); fixed, so both backends order triangles alike.
constexpr int kMcZChunks = 8;

/// Index of the segment of column (x, y) in z slab `chunk`: slab-major.
KFX_HD inline long long mc_segment(int x, int y, int chunk, int res) {
  return x + static_cast<long long>(y) * res + static_cast<long long>(chunk) * res * res;
}

/// First and one-past-last z of slab `chunk`.
KFX_HD inline void mc_slab(int chunk, int res, int& z_begin, int& z_end) {
  z_begin = chunk * res / kMcZChunks;
  z_end = (chunk + 1) * res / kMcZChunks;
}

/// Runs of 8 voxels along x (one brick wide) in a res³ volume: bricks_per_side(res) per row.
KFX_HD inline long long mc_run_count(int res) {
  return static_cast<long long>(bricks_per_side(res)) * res * res;
}

/// Index of the run holding voxel (x, y, z); runs are in voxel order (x fastest, then y, z).
KFX_HD inline long long mc_run_index(int x, int y, int z, int res) {
  return (x >> kBrickShift) +
         static_cast<long long>(bricks_per_side(res)) * (y + static_cast<long long>(z) * res);
}

/// Byte of voxel (x, y, z) in MarchingCubesArgs::vertex_count: its run's 8 bytes, then x & 7.
KFX_HD inline long long mc_count_index(int x, int y, int z, int res) {
  return (mc_run_index(x, y, z, res) << kBrickShift) + (x & ((1 << kBrickShift) - 1));
}

/// Sign bits of one voxel for brick activity: 1 weighted and inside (tsdf < 0), 2 weighted and
/// outside, 0 unobserved.
KFX_HD inline uint8_t mc_voxel_sign_bits(const Voxel& voxel) {
  if (voxel.weight <= 0) return 0;
  return voxel.tsdf < 0 ? 1 : 2;
}

/// OR of mc_voxel_sign_bits over the voxels of brick (bx, by, bz).
KFX_HD inline uint8_t mc_brick_sign_bits(const VolumeView& v, int bx, int by, int bz) {
  const int side = 1 << kBrickShift;
  const int x_end = mini(v.res, (bx + 1) * side), y_end = mini(v.res, (by + 1) * side),
            z_end = mini(v.res, (bz + 1) * side);
  uint8_t bits = 0;
  for (int z = bz * side; z < z_end; ++z) {
    for (int y = by * side; y < y_end; ++y) {
      for (int x = bx * side; x < x_end; ++x) bits |= mc_voxel_sign_bits(v.at(x, y, z));
    }
  }
  return bits;
}

/// 1 when brick (bx, by, bz) may own a vertex or start a meshed cell: it and the bricks at +1
/// along any axes (they hold every voxel its edges and cells reach) have both a weighted voxel
/// inside and one outside. `sign_bits` holds mc_brick_sign_bits per brick (b³, x fastest).
/// An edge with a vertex joins a weighted inside and a weighted outside voxel; a meshed cell's
/// corners are weighted with both signs; so a brick that is not active owns no vertex and no
/// triangle, and skipping it changes nothing in the mesh.
KFX_HD inline uint8_t mc_brick_active(const uint8_t* sign_bits, int bx, int by, int bz, int b) {
  uint8_t bits = 0;
  for (int k = 0; k < 8; ++k) {
    const int x = bx + (k & 1), y = by + ((k >> 1) & 1), z = bz + (k >> 2);
    if (x < b && y < b && z < b) bits |= sign_bits[x + y * b + static_cast<long long>(z) * b * b];
  }
  return bits == 3 ? 1 : 0;
}

/// True when the passes skip voxel (x, y, z): its brick is not active.
KFX_HD inline bool mc_skips_voxel(const MarchingCubesArgs& a, int x, int y, int z) {
  return a.brick_active && !a.brick_active[a.volume.brick_index(x, y, z)];
}

/// Vertices owned by the voxels of run `run` (0 for a run of a skipped brick, whose bytes are
/// stale): the scan input for MarchingCubesArgs::run_vertex_offset.
KFX_HD inline uint32_t mc_run_vertex_count(const MarchingCubesArgs& a, long long run) {
  const int res = a.volume.res, b = bricks_per_side(res);
  const int bx = static_cast<int>(run % b);
  const long long row = run / b;
  const int y = static_cast<int>(row % res), z = static_cast<int>(row / res);
  const int x = bx << kBrickShift;
  if (mc_skips_voxel(a, x, y, z)) return 0;
  const uint8_t* counts = a.vertex_count + (run << kBrickShift);
  const int lanes = mini(1 << kBrickShift, res - x);  // the last run of a row may be short
  uint32_t total = 0;
  for (int k = 0; k < lanes; ++k) total += counts[k];
  return total;
}

/// Index of the first vertex voxel (x, y, z) owns (pass 2, after the scan).
KFX_HD inline uint32_t mc_voxel_vertex_offset(const MarchingCubesArgs& a, int x, int y, int z) {
  const int res = a.volume.res;
  const long long run = mc_run_index(x, y, z, res);
  const uint8_t* counts = a.vertex_count + (run << kBrickShift);
  uint32_t offset = a.run_vertex_offset[run];
  for (int k = 0; k < (x & ((1 << kBrickShift) - 1)); ++k) offset += counts[k];
  return offset;
}

/// Crossing positions closer than this fraction of a voxel to a corner are moved to it, so
/// vertices on different edges never coincide (no degenerate triangles); the shift, at most
/// 1/64 voxel, is far below the TSDF's own error.
constexpr float kMcMinEdgeFraction = 1.0f / 64.0f;

// The per-voxel bodies below read a map through `Map& v`: the dense cube (const VolumeView) or
// a block map's reader (BlockMapReader, which caches its last block); both answer voxel(),
// contains(), contains_cell(), clamp_lo/hi() and voxel_m().

/// True when the cell with lower corner (x, y, z) exists and all its 8 corners have weight > 0.
template <class Map>
KFX_HD inline bool mc_cell_valid(Map& v, int x, int y, int z) {
  if (!v.contains_cell(x, y, z)) return false;
  for (int c = 0; c < 8; ++c) {
    if (v.voxel(x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1)).weight <= 0) return false;
  }
  return true;
}

/// Case index of cell (x, y, z): bit c set when corner c is inside (tsdf < 0); 0 for an
/// invalid cell.
template <class Map>
KFX_HD inline int mc_cell_case(Map& v, int x, int y, int z) {
  if (!v.contains_cell(x, y, z)) return 0;
  int pattern = 0;
  for (int c = 0; c < 8; ++c) {
    const Voxel corner = v.voxel(x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1));
    if (corner.weight <= 0) return 0;
    if (corner.tsdf < 0) pattern |= 1 << c;
  }
  return pattern;
}

/// True when the edge from voxel (x, y, z) along `axis` carries a vertex: it crosses the zero
/// level between two weighted voxels and belongs to at least one valid cell.
template <class Map>
KFX_HD inline bool mc_edge_has_vertex(Map& v, int x, int y, int z, int axis) {
  const int nx = x + (axis == 0), ny = y + (axis == 1), nz = z + (axis == 2);
  if (!v.contains(nx, ny, nz)) return false;
  const Voxel a = v.voxel(x, y, z), b = v.voxel(nx, ny, nz);
  if (a.weight <= 0 || b.weight <= 0 || (a.tsdf < 0) == (b.tsdf < 0)) return false;
  // The four cells around the edge have lower corners offset by 0 or −1 on the other axes.
  for (int k = 0; k < 4; ++k) {
    const int d1 = -(k & 1), d2 = -(k >> 1);
    const int cx = x + (axis == 0 ? 0 : d1);
    const int cy = y + (axis == 1 ? 0 : (axis == 0 ? d1 : d2));
    const int cz = z + (axis == 2 ? 0 : d2);
    if (mc_cell_valid(v, cx, cy, cz)) return true;
  }
  return false;
}

/// Vertices owned by voxel (x, y, z): one per axis whose edge carries one.
template <class Map>
KFX_HD inline uint32_t mc_owned_vertex_count(Map& v, int x, int y, int z) {
  return static_cast<uint32_t>(mc_edge_has_vertex(v, x, y, z, 0)) +
         mc_edge_has_vertex(v, x, y, z, 1) + mc_edge_has_vertex(v, x, y, z, 2);
}

/// Stored tsdf as a float, the voxel index clamped into the volume.
template <class Map>
KFX_HD inline float mc_tsdf_clamped(Map& v, int x, int y, int z) {
  return static_cast<float>(
      v.voxel(v.clamp_hi(v.clamp_lo(x)), v.clamp_hi(v.clamp_lo(y)), v.clamp_hi(v.clamp_lo(z)))
          .tsdf);
}

/// Central-difference tsdf gradient at voxel (x, y, z) (stored units per voxel, unnormalised).
template <class Map>
KFX_HD inline Vec3f mc_voxel_gradient(Map& v, int x, int y, int z) {
  return {mc_tsdf_clamped(v, x + 1, y, z) - mc_tsdf_clamped(v, x - 1, y, z),
          mc_tsdf_clamped(v, x, y + 1, z) - mc_tsdf_clamped(v, x, y - 1, z),
          mc_tsdf_clamped(v, x, y, z + 1) - mc_tsdf_clamped(v, x, y, z - 1)};
}

/// The vertex on the edge from voxel (x, y, z) along `axis` (which must carry one): the zero
/// of the tsdf interpolated linearly along the edge, and the unit normal from the tsdf
/// gradient interpolated the same way (it points to free space, where the tsdf grows).
template <class Map>
KFX_HD inline MeshVertex mc_edge_vertex(Map& v, int x, int y, int z, int axis) {
  const int nx = x + (axis == 0), ny = y + (axis == 1), nz = z + (axis == 2);
  const float a = v.voxel(x, y, z).tsdf, b = v.voxel(nx, ny, nz).tsdf;
  const float t = min_f(max_f(a / (a - b), kMcMinEdgeFraction), 1.0f - kMcMinEdgeFraction);
  const float vox = v.voxel_m();
  MeshVertex out;
  out.p_m = {(x + 0.5f + (axis == 0 ? t : 0.0f)) * vox, (y + 0.5f + (axis == 1 ? t : 0.0f)) * vox,
             (z + 0.5f + (axis == 2 ? t : 0.0f)) * vox};
  const Vec3f ga = mc_voxel_gradient(v, x, y, z), gb = mc_voxel_gradient(v, nx, ny, nz);
  const Vec3f g{ga.x + t * (gb.x - ga.x), ga.y + t * (gb.y - ga.y), ga.z + t * (gb.z - ga.z)};
  const float length = sqrtf(g.x * g.x + g.y * g.y + g.z * g.z);
  const float inv = length > 0.0f ? 1.0f / length : 0.0f;
  out.normal = {g.x * inv, g.y * inv, g.z * inv};
  return out;
}

/// Pass 1 for segment (x, y, chunk): every voxel's owned vertex count, and the segment's
/// triangle count.
KFX_HD inline void mc_count_column(int x, int y, int chunk, const MarchingCubesArgs& a) {
  const VolumeView& v = a.volume;
  uint32_t triangles = 0;
  int z_begin = 0, z_end = 0;
  mc_slab(chunk, v.res, z_begin, z_end);
  for (int z = z_begin; z < z_end; ++z) {
    if (mc_skips_voxel(a, x, y, z)) {  // on to the next brick
      z |= (1 << kBrickShift) - 1;
      continue;
    }
    uint8_t& count = a.vertex_count[mc_count_index(x, y, z, v.res)];
    // Fast path: a voxel without weight owns nothing and starts no valid cell.
    if (v.at(x, y, z).weight <= 0) {
      count = 0;
      continue;
    }
    count = static_cast<uint8_t>(mc_owned_vertex_count(v, x, y, z));
    triangles += a.table->triangle_count[mc_cell_case(v, x, y, z)];
  }
  a.triangle_offset[mc_segment(x, y, chunk, v.res)] = triangles;
}

/// Index of the vertex on the edge from voxel (x, y, z) along `axis` (pass 2, after the scan):
/// the voxel's offset plus the vertices it owns on lower axes.
KFX_HD inline int32_t mc_vertex_index(const MarchingCubesArgs& a, int x, int y, int z, int axis) {
  const VolumeView& v = a.volume;
  uint32_t index = mc_voxel_vertex_offset(a, x, y, z);
  for (int lower = 0; lower < axis; ++lower) index += mc_edge_has_vertex(v, x, y, z, lower);
  return static_cast<int32_t>(index);
}

/// Pass 2 for segment (x, y, chunk): writes the vertices its voxels own and the triangles of its
/// cells.
KFX_HD inline void mc_write_column(int x, int y, int chunk, const MarchingCubesArgs& a) {
  const VolumeView& v = a.volume;
  uint32_t triangle = a.triangle_offset[mc_segment(x, y, chunk, v.res)];
  int z_begin = 0, z_end = 0;
  mc_slab(chunk, v.res, z_begin, z_end);
  for (int z = z_begin; z < z_end; ++z) {
    if (mc_skips_voxel(a, x, y, z)) {
      z |= (1 << kBrickShift) - 1;
      continue;
    }
    if (v.at(x, y, z).weight <= 0) continue;
    uint32_t vertex = mc_voxel_vertex_offset(a, x, y, z);
    for (int axis = 0; axis < 3; ++axis) {
      if (mc_edge_has_vertex(v, x, y, z, axis))
        a.vertices[vertex++] = mc_edge_vertex(v, x, y, z, axis);
    }
    const int pattern = mc_cell_case(v, x, y, z);
    const int count = a.table->triangle_count[pattern];
    for (int t = 0; t < count; ++t) {
      MeshTriangle out;
      for (int k = 0; k < 3; ++k) {
        const int edge = a.table->edges[pattern][3 * t + k];
        const int c = mc_edge_lower_corner(edge);
        out.v[k] = mc_vertex_index(a, x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1),
                                   mc_edge_axis(edge));
      }
      a.triangles[triangle++] = out;
    }
  }
}

}  // namespace kfx
