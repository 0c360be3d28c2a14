#include "output/mesh_view.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <unordered_map>

#include "core/platform.hpp"

namespace kfx::output {

ViewMesh read_view_mesh(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  KFX_CHECK(in, "cannot open mesh '" << path << "'");
  const char* expected[] = {"ply",
                            "format binary_little_endian 1.0",
                            "element vertex",
                            "property float x",
                            "property float y",
                            "property float z",
                            "property float nx",
                            "property float ny",
                            "property float nz",
                            "element face",
                            "property list uchar int vertex_indices",
                            "end_header"};
  size_t vertices = 0, faces = 0;
  std::string line;
  for (const char* want_text : expected) {
    do {
      KFX_CHECK(std::getline(in, line), path << ": PLY header ends before '" << want_text << "'");
      if (!line.empty() && line.back() == '\r') line.pop_back();
    } while (line.rfind("comment", 0) == 0 || line.rfind("obj_info", 0) == 0);
    const std::string want = want_text;
    if (want.rfind("element", 0) == 0) {
      KFX_CHECK(line.rfind(want + " ", 0) == 0,
                path << ": expected '" << want << " N' in the PLY header, found '" << line << "'");
      std::istringstream count(line.substr(want.size() + 1));
      size_t n = 0;
      KFX_CHECK(count >> n, path << ": bad count in '" << line << "'");
      (want == "element vertex" ? vertices : faces) = n;
    } else {
      KFX_CHECK(line == want, path << ": expected '" << want << "' in the PLY header, found '"
                                   << line << "' (kfx reads its own mesh layout only)");
    }
  }
  ViewMesh mesh;
  mesh.source_vertices = vertices;
  mesh.source_triangles = faces;
  std::vector<float> record(6);
  mesh.positions_m.resize(vertices * 3);
  for (size_t i = 0; i < vertices; ++i) {
    KFX_CHECK(in.read(reinterpret_cast<char*>(record.data()), 6 * sizeof(float)),
              path << ": truncated at vertex " << i << " of " << vertices);
    std::copy(record.begin(), record.begin() + 3, mesh.positions_m.begin() + 3 * i);
  }
  mesh.triangles.reserve(faces * 3);
  for (size_t i = 0; i < faces; ++i) {
    unsigned char n = 0;
    int32_t index[3];
    KFX_CHECK(in.read(reinterpret_cast<char*>(&n), 1), path << ": truncated at face " << i);
    KFX_CHECK(n == 3, path << ": face " << i << " has " << int(n) << " vertices, not 3");
    KFX_CHECK(in.read(reinterpret_cast<char*>(index), sizeof(index)),
              path << ": truncated at face " << i << " of " << faces);
    for (int32_t v : index) {
      KFX_CHECK(v >= 0 && static_cast<size_t>(v) < vertices,
                path << ": face " << i << " refers to vertex " << v << " of " << vertices);
      mesh.triangles.push_back(static_cast<uint32_t>(v));
    }
  }
  return mesh;
}

namespace {

/// One clustering pass with cubic cells of `cell_m` from `origin`.
ViewMesh cluster(const ViewMesh& mesh, const float origin[3], float cell_m) {
  ViewMesh out;
  out.source_vertices = mesh.source_vertices;
  out.source_triangles = mesh.source_triangles;
  out.cell_m = cell_m;
  std::unordered_map<uint64_t, uint32_t> cell_vertex;
  std::vector<double> sums;
  std::vector<uint32_t> counts;
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
      counts.push_back(0);
    }
    for (int a = 0; a < 3; ++a) sums[3 * it->second + a] += mesh.positions_m[3 * i + a];
    ++counts[it->second];
    remap[i] = it->second;
  }
  out.positions_m.resize(sums.size());
  for (size_t v = 0; v < counts.size(); ++v) {
    for (int a = 0; a < 3; ++a)
      out.positions_m[3 * v + a] = static_cast<float>(sums[3 * v + a] / counts[v]);
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
