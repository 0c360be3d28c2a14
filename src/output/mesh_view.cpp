#include "output/mesh_view.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <unordered_map>

#include "core/platform.hpp"
#include "output/mesh_ply.hpp"

namespace kfx::output {

ViewMesh read_view_mesh(const std::string& path) {
  // The one PLY reader (mesh_ply.hpp) checks the layout; the view keeps positions and indices.
  const Mesh mesh = read_mesh_ply(path);
  ViewMesh view;
  view.source_vertices = mesh.vertices.size();
  view.source_triangles = mesh.triangles.size();
  view.positions_m.reserve(mesh.vertices.size() * 3);
  for (const MeshVertex& v : mesh.vertices) {
    view.positions_m.insert(view.positions_m.end(), {v.p_m.x, v.p_m.y, v.p_m.z});
  }
  for (const Rgb8& c : mesh.colours) view.colours.insert(view.colours.end(), {c.r, c.g, c.b});
  view.triangles.reserve(mesh.triangles.size() * 3);
  for (const MeshTriangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) view.triangles.push_back(static_cast<uint32_t>(t.v[k]));
  }
  return view;
}

namespace {

/// One clustering pass with cubic cells of `cell_m` from `origin`.
ViewMesh cluster(const ViewMesh& mesh, const float origin[3], float cell_m) {
  ViewMesh out;
  out.source_vertices = mesh.source_vertices;
  out.source_triangles = mesh.source_triangles;
  out.cell_m = cell_m;
  std::unordered_map<uint64_t, uint32_t> cell_vertex;
  std::vector<double> sums, colour_sums;
  std::vector<uint32_t> counts;
  const bool colour = !mesh.colours.empty();
  std::vector<uint32_t> remap(mesh.vertex_count());
  for (size_t i = 0; i < mesh.vertex_count(); ++i) {
    uint64_t key = 0;
    for (int a = 0; a < 3; ++a) {
      const auto c = static_cast<uint64_t>((mesh.positions_m[3 * i + a] - origin[a]) / cell_m);
      key = (key << 21) | (c & 0x1fffff);
    }
    const auto [it, added] = cell_vertex.emplace(key, static_cast<uint32_t>(counts.size()));
    if (added) {
      sums.insert(sums.end(), {0.0, 0.0, 0.0});
      if (colour) colour_sums.insert(colour_sums.end(), {0.0, 0.0, 0.0});
      counts.push_back(0);
    }
    for (int a = 0; a < 3; ++a) sums[3 * it->second + a] += mesh.positions_m[3 * i + a];
    if (colour) {
      for (int a = 0; a < 3; ++a) colour_sums[3 * it->second + a] += mesh.colours[3 * i + a];
    }
    ++counts[it->second];
    remap[i] = it->second;
  }
  out.positions_m.resize(sums.size());
  out.colours.resize(colour_sums.size());
  for (size_t v = 0; v < counts.size(); ++v) {
    for (int a = 0; a < 3; ++a)
      out.positions_m[3 * v + a] = static_cast<float>(sums[3 * v + a] / counts[v]);
    for (int a = 0; a < 3 && colour; ++a) {
      out.colours[3 * v + a] =
          static_cast<uint8_t>(std::lround(colour_sums[3 * v + a] / counts[v]));
    }
  }
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const uint32_t a = remap[mesh.triangles[3 * t]], b = remap[mesh.triangles[3 * t + 1]],
                   c = remap[mesh.triangles[3 * t + 2]];
    if (a != b && b != c && a != c) out.triangles.insert(out.triangles.end(), {a, b, c});
  }
  return out;
}

}  // namespace

ViewMesh thin_for_view(const ViewMesh& mesh, size_t max_triangles) {
  if (mesh.triangle_count() <= max_triangles || mesh.vertex_count() == 0) return mesh;
  float lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = mesh.positions_m[a];
  for (size_t i = 0; i < mesh.vertex_count(); ++i) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], mesh.positions_m[3 * i + a]);
      hi[a] = std::max(hi[a], mesh.positions_m[3 * i + a]);
    }
  }
  const float extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-6f});
  // 21 bits per axis in the cell key: the cell must stay above extent / 2²¹.
  for (float cell = extent / 1024.0f;; cell *= 2.0f) {
    ViewMesh thinned = cluster(mesh, lo, cell);
    if (thinned.triangle_count() <= max_triangles) return thinned;
  }
}

}  // namespace kfx::output
