/// Mesh extraction (kernels/marching_cubes.hpp) and the mesh, cloud and volume files: the case
/// table's topology, a sphere with an analytic answer, shared vertices and a closed surface, no
/// degenerate faces, the weight rule, determinism, PLY layout and round trips, CPU vs GPU.

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "backend/backend.hpp"
#include "kernels/marching_cubes.hpp"
#include "output/mesh_ply.hpp"
#include "output/volume_file.hpp"
#include "support/mesh_test_support.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;

std::unique_ptr<Backend> mesher(BackendKind kind, int res, float size_m) {
  BackendSetup setup;
  setup.input_width_px = 8;
  setup.input_height_px = 8;
  setup.compute_ratio = 1;
  setup.pyramid_levels = 1;
  setup.volume_res_vox = res;
  setup.volume_size_m = size_m;
  return make_backend(kind, setup);
}

Mesh mesh_of(const std::vector<Voxel>& voxels, int res, float size_m,
             BackendKind kind = BackendKind::kCpu) {
  auto backend = mesher(kind, res, size_m);
  backend->upload_volume(voxels);
  return Mesh(backend->extract_mesh());
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string temp_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("kfx_test_mesh_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

// Sphere of radius 0.3 m in a 1 m, 64³ volume (15.6 mm voxels), mu 0.1 m.
constexpr int kRes = 64;
constexpr float kSize_m = 1.0f;
constexpr float kRadius_m = 0.3f;
const Vec3f kCentre{0.51f, 0.49f, 0.5f};  // off the voxel grid's symmetry

Mesh sphere_mesh(BackendKind kind = BackendKind::kCpu) {
  return mesh_of(test::sphere_volume(kRes, kSize_m, kCentre, kRadius_m, 0.1f), kRes, kSize_m, kind);
}

TEST(MarchingCubesTable, EveryCrossedEdgeAndOnlyThoseAreUsed) {
  for (int pattern = 0; pattern < 256; ++pattern) {
    std::set<int> crossed, used;
    for (int e = 0; e < 12; ++e) {
      const int a = mc_edge_lower_corner(e), b = a | (1 << mc_edge_axis(e));
      if (((pattern >> a) & 1) != ((pattern >> b) & 1)) crossed.insert(e);
    }
    const int n = kMcTable.triangle_count[pattern];
    ASSERT_LE(n, kMcMaxTriangles);
    for (int i = 0; i < 3 * n; ++i) used.insert(kMcTable.edges[pattern][i]);
    EXPECT_EQ(crossed, used) << "case " << pattern;
    for (int t = 0; t < n; ++t) {  // three different edges per triangle
      const int8_t* e = kMcTable.edges[pattern] + 3 * t;
      EXPECT_TRUE(e[0] != e[1] && e[1] != e[2] && e[0] != e[2]) << "case " << pattern;
    }
  }
  EXPECT_EQ(kMcTable.triangle_count[0], 0);
  EXPECT_EQ(kMcTable.triangle_count[255], 0);
  EXPECT_EQ(kMcTable.triangle_count[1], 1);
}

TEST(MarchingCubes, SphereVerticesLieOnTheSphereWithRadialNormals) {
  const Mesh mesh = sphere_mesh();
  ASSERT_GT(mesh.vertices.size(), 1000u);
  double worst_m = 0, worst_dot = 1;
  for (const auto& v : mesh.vertices) {
    const Vec3f d{v.p_m.x - kCentre.x, v.p_m.y - kCentre.y, v.p_m.z - kCentre.z};
    const double r = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    worst_m = std::max(worst_m, std::fabs(r - kRadius_m));
    worst_dot = std::min(worst_dot, (d.x * v.normal.x + d.y * v.normal.y + d.z * v.normal.z) / r);
  }
  // Linear interpolation of a sampled sphere: the chord error of 15.6 mm voxels on a 0.3 m
  // radius is about v²/(8r) ≈ 0.1 mm, plus int16 rounding; 1 mm leaves room, 1/16 voxel.
  EXPECT_LT(worst_m, 0.001);
  EXPECT_GT(worst_dot, 0.99);  // normals from the tsdf gradient point outward, radially
}

TEST(MarchingCubes, ClosedSurfaceWithSharedVerticesAndNoDegenerateFaces) {
  const Mesh mesh = sphere_mesh();
  std::map<std::pair<int, int>, int> edge_uses;
  std::vector<int> vertex_uses(mesh.vertices.size(), 0);
  for (const auto& t : mesh.triangles) {
    const Vec3f a = mesh.vertices[t.v[0]].p_m, b = mesh.vertices[t.v[1]].p_m,
                c = mesh.vertices[t.v[2]].p_m;
    ASSERT_TRUE(t.v[0] != t.v[1] && t.v[1] != t.v[2] && t.v[0] != t.v[2]);
    const Vec3f n = cross(b - a, c - a);
    const double area2 = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    ASSERT_GT(area2, 0.0);
    // Winding: counter-clockwise seen from outside, like the normals.
    const Vec3f vn = mesh.vertices[t.v[0]].normal;
    EXPECT_GT(n.x * vn.x + n.y * vn.y + n.z * vn.z, 0.0);
    for (int k = 0; k < 3; ++k) {
      ++vertex_uses[t.v[k]];
      const int i = t.v[k], j = t.v[(k + 1) % 3];
      ++edge_uses[{std::min(i, j), std::max(i, j)}];
    }
  }
  // A closed 2-manifold: every edge in exactly two triangles, every vertex used, and Euler's
  // V − E + F = 2 for a sphere. Triangle soup would fail all three.
  for (const auto& [edge, uses] : edge_uses) ASSERT_EQ(uses, 2);
  for (int uses : vertex_uses) ASSERT_GT(uses, 0);
  const long long euler = static_cast<long long>(mesh.vertices.size()) -
                          static_cast<long long>(edge_uses.size()) +
                          static_cast<long long>(mesh.triangles.size());
  EXPECT_EQ(euler, 2);
}

TEST(MarchingCubes, OnlyCellsWithEveryCornerObservedAreMeshed) {
  auto voxels = test::sphere_volume(kRes, kSize_m, kCentre, kRadius_m, 0.1f);
  const VolumeView view{voxels.data(), kRes, kSize_m, nullptr};
  const int cut = kRes / 2;
  for (int z = 0; z < kRes; ++z) {
    for (int y = 0; y < kRes; ++y) {
      for (int x = 0; x < cut; ++x) view.at(x, y, z).weight = 0;
    }
  }
  const Mesh mesh = mesh_of(voxels, kRes, kSize_m);
  ASSERT_GT(mesh.triangles.size(), 100u);
  for (const auto& v : mesh.vertices) ASSERT_GE(v.p_m.x, view.centre_m(cut, 0, 0).x);
  // Nothing observed, nothing meshed.
  for (auto& voxel : voxels) voxel.weight = 0;
  const Mesh empty = mesh_of(voxels, kRes, kSize_m);
  EXPECT_TRUE(empty.vertices.empty());
  EXPECT_TRUE(empty.triangles.empty());
}

TEST(MarchingCubes, SameBytesRunToRun) {
  const std::string dir = temp_dir("determinism");
  output::write_mesh_ply(dir + "/a.ply", sphere_mesh(), "test");
  output::write_mesh_ply(dir + "/b.ply", sphere_mesh(), "test");
  const std::string a = read_bytes(dir + "/a.ply");
  EXPECT_GT(a.size(), 10000u);
  EXPECT_EQ(a, read_bytes(dir + "/b.ply"));
}

/// The mesh from the kernel bodies alone, serially, with no brick skipped: what the backends,
/// which skip inactive bricks, must reproduce byte for byte.
Mesh unskipped_mesh(std::vector<Voxel> voxels, int res, float size_m) {
  const long long runs = mc_run_count(res);
  std::vector<uint8_t> counts(static_cast<size_t>(runs) << kBrickShift);
  std::vector<uint32_t> run_offsets(static_cast<size_t>(runs) + 1);
  std::vector<uint32_t> triangle_offsets(static_cast<size_t>(kMcZChunks) * res * res + 1, 0);
  MarchingCubesArgs a{VolumeView{voxels.data(), res, size_m, nullptr},
                      &kMcTable,
                      nullptr,
                      counts.data(),
                      run_offsets.data(),
                      triangle_offsets.data(),
                      nullptr,
                      nullptr};
  for (int chunk = 0; chunk < kMcZChunks; ++chunk) {
    for (int y = 0; y < res; ++y) {
      for (int x = 0; x < res; ++x) mc_count_column(x, y, chunk, a);
    }
  }
  uint32_t vertices = 0, triangles = 0;
  for (long long run = 0; run < runs; ++run) {
    run_offsets[run] = vertices;
    vertices += mc_run_vertex_count(a, run);
  }
  run_offsets.back() = vertices;
  for (uint32_t& offset : triangle_offsets) {
    const uint32_t count = offset;
    offset = triangles;
    triangles += count;
  }
  Mesh mesh;
  mesh.vertices.resize(vertices);
  mesh.triangles.resize(triangles);
  a.vertices = mesh.vertices.data();
  a.triangles = mesh.triangles.data();
  for (int chunk = 0; chunk < kMcZChunks; ++chunk) {
    for (int y = 0; y < res; ++y) {
      for (int x = 0; x < res; ++x) mc_write_column(x, y, chunk, a);
    }
  }
  return mesh;
}

TEST(MarchingCubes, SkippingInactiveBricksChangesNoByte) {
  // 61³ (bricks and runs cut short at the far faces), a sphere with a third of the volume
  // unobserved: bricks far from the surface, unobserved and cut by the boundary all occur.
  constexpr int res = 61;
  auto voxels = test::sphere_volume(res, kSize_m, kCentre, kRadius_m, 0.1f);
  const VolumeView view{voxels.data(), res, kSize_m, nullptr};
  for (int z = 0; z < res; ++z) {
    for (int y = 0; y < res; ++y) {
      for (int x = 0; x < res / 3; ++x) view.at(x, y, z).weight = 0;
    }
  }
  const Mesh reference = unskipped_mesh(voxels, res, kSize_m);
  ASSERT_GT(reference.triangles.size(), 1000u);
  // Some bricks are inactive, so the backends do skip.
  const int b = bricks_per_side(res);
  std::vector<uint8_t> signs;
  for (int bz = 0; bz < b; ++bz) {
    for (int by = 0; by < b; ++by) {
      for (int bx = 0; bx < b; ++bx) signs.push_back(mc_brick_sign_bits(view, bx, by, bz));
    }
  }
  int inactive = 0;
  for (int i = 0; i < b * b * b; ++i) {
    inactive += !mc_brick_active(signs.data(), i % b, i / b % b, i / b / b, b);
  }
  EXPECT_GT(inactive, b * b * b / 2);
  EXPECT_TRUE(test::same_mesh_bytes(mesh_of(voxels, res, kSize_m), reference));
  std::string why_not;
  if (cuda_available(&why_not)) {
    // The GPU's positions may differ by FMA rounding; its topology and order may not.
    const Mesh gpu = mesh_of(voxels, res, kSize_m, BackendKind::kCuda);
    ASSERT_EQ(gpu.vertices.size(), reference.vertices.size());
    ASSERT_EQ(gpu.triangles.size(), reference.triangles.size());
    EXPECT_EQ(std::memcmp(gpu.triangles.data(), reference.triangles.data(),
                          gpu.triangles.size() * sizeof(MeshTriangle)),
              0);
  }
}

TEST(MarchingCubes, ExtractionReusesTheBackendsArrays) {
  // A later extraction of a smaller mesh writes into the same arrays (nothing allocated) and
  // gives its own sizes and bytes; on the GPU as on the CPU when a GPU is present.
  const auto small_volume = test::sphere_volume(kRes, kSize_m, kCentre, 0.5f * kRadius_m, 0.1f);
  const Mesh reference = unskipped_mesh(small_volume, kRes, kSize_m);
  std::vector<BackendKind> kinds{BackendKind::kCpu};
  if (cuda_available()) kinds.push_back(BackendKind::kCuda);
  for (BackendKind kind : kinds) {
    auto backend = mesher(kind, kRes, kSize_m);
    backend->upload_volume(test::sphere_volume(kRes, kSize_m, kCentre, kRadius_m, 0.1f));
    const MeshView large = backend->extract_mesh();
    const size_t large_vertices = large.vertex_count;
    backend->upload_volume(small_volume);
    const MeshView small = backend->extract_mesh();
    EXPECT_EQ(small.vertices, large.vertices);
    EXPECT_EQ(small.triangles, large.triangles);
    EXPECT_LT(small.vertex_count, large_vertices / 2);
    ASSERT_EQ(small.vertex_count, reference.vertices.size());
    ASSERT_EQ(small.triangle_count, reference.triangles.size());
    if (kind == BackendKind::kCpu) EXPECT_TRUE(test::same_mesh_bytes(Mesh(small), reference));
  }
}

TEST(MeshPly, HeaderAndBinaryLayout) {
  Mesh mesh;
  mesh.vertices = {{{1, 2, 3}, {0, 0, 1}}, {{4, 5, 6}, {0, 1, 0}}, {{7, 8, 9}, {1, 0, 0}}};
  mesh.triangles = {{{0, 1, 2}}};
  const std::string dir = temp_dir("layout");
  output::write_mesh_ply(dir + "/m.ply", mesh, "hello");
  const std::string bytes = read_bytes(dir + "/m.ply");
  const std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment hello\nelement vertex 3\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n";
  ASSERT_EQ(bytes.substr(0, header.size()), header);
  ASSERT_EQ(bytes.size(), header.size() + 3 * 24 + 13);
  float x = 0, nz = 0;
  std::memcpy(&x, bytes.data() + header.size() + 24, 4);      // vertex 1, x
  std::memcpy(&nz, bytes.data() + header.size() + 5 * 4, 4);  // vertex 0, nz
  EXPECT_EQ(x, 4.0f);
  EXPECT_EQ(nz, 1.0f);
  const size_t face = header.size() + 72;
  EXPECT_EQ(static_cast<unsigned char>(bytes[face]), 3);
  int32_t i2 = 0;
  std::memcpy(&i2, bytes.data() + face + 1 + 8, 4);
  EXPECT_EQ(i2, 2);
  EXPECT_FALSE(fs::exists(dir + "/m.ply.tmp"));
}

TEST(MeshPly, RoundTripAndEmpty) {
  const std::string dir = temp_dir("roundtrip");
  const Mesh mesh = sphere_mesh();
  output::write_mesh_ply(dir + "/s.ply", mesh, "");
  const Mesh back = output::read_mesh_ply(dir + "/s.ply");
  ASSERT_EQ(back.vertices.size(), mesh.vertices.size());
  ASSERT_EQ(back.triangles.size(), mesh.triangles.size());
  EXPECT_EQ(std::memcmp(back.vertices.data(), mesh.vertices.data(),
                        mesh.vertices.size() * sizeof(MeshVertex)),
            0);
  EXPECT_EQ(std::memcmp(back.triangles.data(), mesh.triangles.data(),
                        mesh.triangles.size() * sizeof(MeshTriangle)),
            0);
  output::write_mesh_ply(dir + "/e.ply", Mesh{}, "empty");
  const Mesh empty = output::read_mesh_ply(dir + "/e.ply");
  EXPECT_TRUE(empty.vertices.empty() && empty.triangles.empty());
  // A truncated file is named as such.
  const std::string bytes = read_bytes(dir + "/s.ply");
  std::ofstream(dir + "/t.ply", std::ios::binary) << bytes.substr(0, bytes.size() - 5);
  try {
    output::read_mesh_ply(dir + "/t.ply");
    FAIL() << "a truncated PLY was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("t.ply"), std::string::npos) << e.what();
  }
}

TEST(VolumeFile, RoundTripAndBadInput) {
  const std::string dir = temp_dir("volume");
  output::SavedVolume v;
  v.res = 16;
  v.size_m = 1.5f;
  v.voxels = test::sphere_volume(16, 1.5f, {0.7f, 0.7f, 0.7f}, 0.4f, 0.1f);
  output::write_volume_file(dir + "/v.kfxtsdf", v);
  EXPECT_EQ(fs::file_size(dir + "/v.kfxtsdf"), output::kVolumeHeaderBytes + 4u * 16 * 16 * 16);
  const output::SavedVolume back = output::read_volume_file(dir + "/v.kfxtsdf");
  EXPECT_EQ(back.res, 16);
  EXPECT_EQ(back.size_m, 1.5f);
  EXPECT_EQ(back.T_trajectory_volume.m[0][0], 1.0f);
  EXPECT_EQ(back.T_trajectory_volume.m[0][3], 0.0f);
  EXPECT_EQ(std::memcmp(back.voxels.data(), v.voxels.data(), v.voxels.size() * 4), 0);
  const std::string bytes = read_bytes(dir + "/v.kfxtsdf");
  std::ofstream(dir + "/short.kfxtsdf", std::ios::binary) << bytes.substr(0, bytes.size() - 4);
  EXPECT_THROW(output::read_volume_file(dir + "/short.kfxtsdf"), Error);
  std::string bad = bytes;
  bad[0] = 'X';
  std::ofstream(dir + "/magic.kfxtsdf", std::ios::binary) << bad;
  EXPECT_THROW(output::read_volume_file(dir + "/magic.kfxtsdf"), Error);
}

TEST(MarchingCubesParity, GpuMeshMatchesCpu) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  const Mesh cpu = sphere_mesh(BackendKind::kCpu);
  const Mesh gpu = sphere_mesh(BackendKind::kCuda);
  // Same topology from the same integer volume; positions may differ by FMA rounding.
  const double count_ratio = static_cast<double>(gpu.vertices.size()) / cpu.vertices.size();
  EXPECT_NEAR(count_ratio, 1.0, 0.001);
  EXPECT_LE(std::max(test::directed_hausdorff_m(cpu, gpu, 0.01),
                     test::directed_hausdorff_m(gpu, cpu, 0.01)),
            0.001);
}

}  // namespace
}  // namespace kfx
