#pragma once
/// The mesh as the report's 3D view shows it: read from a run's mesh.ply (binary little-endian,
/// `float x y z nx ny nz`, optionally `uchar red green blue`, faces `list uchar int
/// vertex_indices`) and, when large, thinned by vertex clustering (colours averaged with the
/// positions). mesh.ply itself is never changed.

#include <cstdint>
#include <string>
#include <vector>

namespace kfx::output {

/// Positions and triangles only (the view recomputes normals).
struct ViewMesh {
  std::vector<float> positions_m;   ///< x y z per vertex, metres, volume frame
  std::vector<uint32_t> triangles;  ///< three vertex indices per triangle
  std::vector<uint8_t> colours;     ///< r g b per vertex; empty for a grey mesh
  size_t source_vertices = 0;       ///< counts in mesh.ply, before thinning
  size_t source_triangles = 0;
  float cell_m = 0.0f;  ///< clustering cell size; 0 when not thinned
  size_t vertex_count() const { return positions_m.size() / 3; }
  size_t triangle_count() const { return triangles.size() / 3; }
};

/// Reads a mesh PLY of the layout above (comments allowed). Throws kfx::Error naming the file
/// and the problem for anything else, a truncated file or an index out of range.
ViewMesh read_view_mesh(const std::string& path);

/// Thins `mesh` until it has at most `max_triangles`: vertices in the same cubic cell merge into
/// their mean, triangles that collapse are dropped, the cell doubling from 1/1024 of the
/// bounding box until the count fits. Unchanged when already small enough.
ViewMesh thin_for_view(const ViewMesh& mesh, size_t max_triangles);

}  // namespace kfx::output
