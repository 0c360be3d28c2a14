#pragma once
/// A host triangle mesh: vertices with normals, indexed triangles. Plain data; written to PLY by
/// src/output/mesh_ply.*. MeshView is the same mesh in host memory someone else owns (a
/// backend's reused, on the GPU pinned, output buffers), so extraction needs no fresh copy.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/image.hpp"
#include "core/math.hpp"

namespace kfx {

/// One mesh vertex: position (metres, volume frame) and unit normal, laid out as PLY's
/// `float x y z nx ny nz`.
struct MeshVertex {
  Vec3f p_m;
  Vec3f normal;
};
static_assert(sizeof(MeshVertex) == 6 * sizeof(float), "MeshVertex must be 6 packed floats");

/// One triangle: three vertex indices, counter-clockwise seen from free space (the side the
/// normals point to).
struct MeshTriangle {
  int32_t v[3];
};

/// A read-only view of an indexed triangle mesh in host memory owned elsewhere.
struct MeshView {
  const MeshVertex* vertices = nullptr;
  size_t vertex_count = 0;
  const MeshTriangle* triangles = nullptr;
  size_t triangle_count = 0;
  const Rgb8* colours = nullptr;  ///< one colour per vertex, or null (a grey mesh)
};

/// An indexed triangle mesh on the host.
struct Mesh {
  std::vector<MeshVertex> vertices;
  std::vector<MeshTriangle> triangles;
  std::vector<Rgb8> colours;  ///< one per vertex, or empty (a grey mesh)

  Mesh() = default;
  /// An owning copy of `view`.
  explicit Mesh(const MeshView& view)
      : vertices(view.vertices, view.vertices + view.vertex_count),
        triangles(view.triangles, view.triangles + view.triangle_count) {
    if (view.colours) colours.assign(view.colours, view.colours + view.vertex_count);
  }
  /// A view of this mesh (valid while it is neither changed nor destroyed).
  operator MeshView() const {
    return MeshView{
        vertices.data(), vertices.size(), triangles.data(), triangles.size(),
        colours.size() == vertices.size() && !colours.empty() ? colours.data() : nullptr};
  }
};

}  // namespace kfx
