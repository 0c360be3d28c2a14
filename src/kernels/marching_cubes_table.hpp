#pragma once
/// The marching-cubes case table, derived at compile time from the cube's geometry rather than
/// typed in: for each of the 256 inside/outside patterns of a cell's corners, the surface's
/// boundary on each face is traced, the boundary segments are chained into closed loops, and
/// each loop is fanned into triangles.
///
/// Conventions. Corner c of a cell sits at (c & 1, (c >> 1) & 1, (c >> 2) & 1) voxels from the
/// cell's lower corner; bit c of a case is set when corner c is inside (tsdf < 0). Edge e (0–11)
/// runs along axis e / 4 from corner mc_edge_lower_corner(e) to that corner + 1 along the axis.
/// Faces with two diagonal inside corners are resolved by separating the inside corners, a rule
/// that depends on the face's corners alone, so neighbouring cells agree and the mesh is closed.

#include <cstdint>

#include "core/platform.hpp"

namespace kfx {

/// Most triangles of one cell: a case with E crossed edges in L loops gives E − 2L ≤ 12 − 2.
constexpr int kMcMaxTriangles = 10;

/// Triangles of each case, as cell edges; counter-clockwise seen from outside (tsdf > 0).
struct McTable {
  uint8_t triangle_count[256];
  int8_t edges[256][3 * kMcMaxTriangles];
};

/// The corner an edge starts from (its lower end along the edge's axis).
KFX_HD constexpr int mc_edge_lower_corner(int edge) {
  const int axis = edge >> 2, k = edge & 3;
  const int first_other = axis == 0 ? 1 : 0;   // the two other axes, in increasing order,
  const int second_other = axis == 2 ? 1 : 2;  // take the bits of k
  return ((k & 1) << first_other) | ((k >> 1) << second_other);
}

/// The axis (0 x, 1 y, 2 z) an edge runs along.
KFX_HD constexpr int mc_edge_axis(int edge) { return edge >> 2; }

/// The edge joining two corners that differ in one coordinate.
constexpr int mc_edge_between(int corner_a, int corner_b) {
  const int diff = corner_a ^ corner_b;
  const int axis = diff == 1 ? 0 : diff == 2 ? 1 : 2;
  const int lower = corner_a & corner_b;
  const int first_other = axis == 0 ? 1 : 0;
  const int second_other = axis == 2 ? 1 : 2;
  return axis * 4 + ((lower >> first_other) & 1) + (((lower >> second_other) & 1) << 1);
}

/// Builds the table (see the file comment).
constexpr McTable make_mc_table() {
  McTable table{};
  for (int pattern = 0; pattern < 256; ++pattern) {
    auto inside = [pattern](int corner) { return ((pattern >> corner) & 1) != 0; };
    // next[e]: the edge where the surface boundary continues after edge e (−1: e not crossed).
    int next[12] = {-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1};
    for (int axis = 0; axis < 3; ++axis) {
      for (int side = 0; side < 2; ++side) {
        // Face corners counter-clockwise seen from outside the cell: (u, w, axis) is
        // right-handed, so the unit square in (u, w) runs counter-clockwise seen from +axis.
        const int u = 1 << ((axis + 1) % 3), w = 1 << ((axis + 2) % 3);
        const int base = side << axis;
        int q[4] = {base, base | u, base | u | w, base | w};
        if (side == 0) {  // seen from −axis: reverse
          const int t = q[1];
          q[1] = q[3];
          q[3] = t;
        }
        // Each run of inside corners is cut off by one segment, from the edge where the run
        // begins to the edge where it ends (in face order).
        for (int i = 0; i < 4; ++i) {
          const int prev = q[(i + 3) % 4];
          if (!inside(q[i]) || inside(prev)) continue;
          int j = i;
          while (inside(q[(j + 1) % 4])) j = (j + 1) % 4;  // ends: prev is outside
          next[mc_edge_between(prev, q[i])] = mc_edge_between(q[j], q[(j + 1) % 4]);
        }
      }
    }
    // Each crossed edge has one segment in and one out, so the segments form closed loops.
    bool used[12] = {};
    int triangles = 0;
    for (int start = 0; start < 12; ++start) {
      if (next[start] < 0 || used[start]) continue;
      int loop[12] = {};
      int length = 0;
      for (int e = start; !used[e]; e = next[e]) {
        used[e] = true;
        loop[length++] = e;
      }
      for (int i = 1; i + 1 < length; ++i) {
        int8_t* out = table.edges[pattern] + 3 * triangles++;
        out[0] = static_cast<int8_t>(loop[0]);
        out[1] = static_cast<int8_t>(loop[i]);
        out[2] = static_cast<int8_t>(loop[i + 1]);
      }
    }
    table.triangle_count[pattern] = static_cast<uint8_t>(triangles);
  }
  return table;
}

/// The table, built once by the compiler. Device code reads a copy the CUDA backend uploads.
inline constexpr McTable kMcTable = make_mc_table();

}  // namespace kfx
