/// Marching cubes over a host block map: the three passes of marching_cubes_blocks.hpp.

#include "backend/block_map_mesh.hpp"

#include <algorithm>
#include <cstdint>

#include "kernels/marching_cubes_blocks.hpp"
#include "map/block_map_index.hpp"

namespace kfx {
namespace {

/// Exclusive prefix sum in place over all but the last entry, which receives the total; throws
/// when the total exceeds PLY's int indices.
size_t exclusive_scan(std::vector<uint32_t>& counts, const char* what) {
  uint64_t total = 0;
  for (size_t i = 0; i + 1 < counts.size(); ++i) {
    const uint32_t count = counts[i];
    counts[i] = static_cast<uint32_t>(total);
    total += count;
  }
  KFX_CHECK(total <= 0x7fffffffu,
            "the mesh has " << total << " " << what << ", more than PLY's int indices address");
  counts.back() = static_cast<uint32_t>(total);
  return static_cast<size_t>(total);
}

}  // namespace

MeshView extract_block_map_mesh(const BlockMapView& map, std::vector<MeshVertex>& vertices,
                                std::vector<MeshTriangle>& triangles) {
  const int n = map.block_count;
  std::vector<uint8_t> signs(static_cast<size_t>(n));
#pragma omp parallel for schedule(static)
  for (int b = 0; b < n; ++b) signs[b] = mc_map_block_sign_bits(map, b);
  std::vector<int32_t> active;  // block indices, in increasing key order
  std::vector<uint8_t> is_active(static_cast<size_t>(n));
#pragma omp parallel for schedule(static)
  for (int b = 0; b < n; ++b) is_active[b] = mc_map_block_active(map, signs.data(), b);
  for (int b = 0; b < n; ++b) {
    if (is_active[b]) active.push_back(b);
  }
  std::sort(active.begin(), active.end(),
            [&](int32_t l, int32_t r) { return map.block_keys[l] < map.block_keys[r]; });
  std::vector<int32_t> slot(static_cast<size_t>(n), -1);
  for (size_t s = 0; s < active.size(); ++s) slot[active[s]] = static_cast<int32_t>(s);
  const int slots = static_cast<int>(active.size());
  std::vector<uint32_t> first_vertex(static_cast<size_t>(slots) * kBlockVoxels);
  std::vector<uint32_t> vertex_offset(static_cast<size_t>(slots) + 1, 0);
  std::vector<uint32_t> triangle_offset(static_cast<size_t>(slots) + 1, 0);
  BlockMeshArgs a{map,
                  &kMcTable,
                  active.data(),
                  slot.data(),
                  first_vertex.data(),
                  vertex_offset.data(),
                  triangle_offset.data(),
                  nullptr,
                  nullptr};
#pragma omp parallel for schedule(dynamic, 8)
  for (int s = 0; s < slots; ++s) mc_count_block(s, a);
  const size_t vertex_total = exclusive_scan(vertex_offset, "vertices");
  const size_t triangle_total = exclusive_scan(triangle_offset, "triangles");
  if (vertices.size() < vertex_total) vertices.resize(vertex_total);
  if (triangles.size() < triangle_total) triangles.resize(triangle_total);
  a.vertices = vertices.data();
  a.triangles = triangles.data();
#pragma omp parallel for schedule(dynamic, 8)
  for (int s = 0; s < slots; ++s) mc_write_block(s, a);
  return MeshView{vertices.data(), vertex_total, triangles.data(), triangle_total};
}

MeshView extract_block_map_mesh(const BlockMapContents& contents, std::vector<MeshVertex>& vertices,
                                std::vector<MeshTriangle>& triangles) {
  // The index only: the mesh reads the contents' own voxels (no second copy of the map).
  HostBlockMap index = index_of_contents(contents);
  return extract_block_map_mesh(index.view_of_contents(contents), vertices, triangles);
}

}  // namespace kfx
