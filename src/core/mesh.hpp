#pragma once
/// A host triangle mesh: vertices with normals, indexed triangles. Plain data; written to PLY by
/// src/output/mesh_ply.*.

#include <cstdint>
#include <vector>

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

/// An indexed triangle mesh on the host.
struct Mesh {
  std::vector<MeshVertex> vertices;
  std::vector<MeshTriangle> triangles;
};

}  // namespace kfx
