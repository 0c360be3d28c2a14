/// Several maps in one backend (Backend::create_map, select_map): every stage acts on the
/// selected map only, over each backend × map kind. Two flat walls at different depths are
/// fused into two maps of one backend; each map raycasts and meshes only its own wall, and
/// working on the second leaves the first's bytes as they were. The frames reuse one shape and
/// parity across the maps, so on the GPU a recording made with one map replayed with another
/// (the recorded frame captures the map's memory) would fuse into the wrong map and fail here.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "backend/backend.hpp"
#include "backend/memory_budget.hpp"
#include "kfx/error.hpp"
#include "support/backend_map_params.hpp"

namespace kfx {
namespace {

constexpr int kWidthPx = 160, kHeightPx = 120;
constexpr int kRes = 64;
constexpr float kSizeM = 2.0f;
const Intrinsics kK{120.0f, 120.0f, 79.5f, 59.5f};
/// The two walls, metres in front of the camera (the camera looks along +z from z = 0).
constexpr float kNearWallM = 0.8f, kFarWallM = 1.3f;
/// A wall's surface is found within half a voxel and a little (trilinear reads, 64³ over 2 m).
constexpr float kSurfaceTolM = 0.6f * kSizeM / kRes;
/// The frame shapes: fuse (integration forced) and look (no integration), both rendering.
constexpr int kFuseShape = 2 | 4 | 8 | 16, kLookShape = 2 | 8 | 16;

BackendSetup setup_for(MapKind kind) {
  BackendSetup s;
  s.input_width_px = kWidthPx;
  s.input_height_px = kHeightPx;
  s.compute_ratio = 1;
  s.pyramid_levels = 3;
  s.volume_res_vox = kRes;
  s.volume_size_m = kSizeM;
  s.map_kind = kind;
  if (kind == MapKind::kBlocks) s.block_capacity = 4096;
  return s;
}

HostImage<uint16_t> wall_mm(float depth_m) {
  HostImage<uint16_t> d(kWidthPx, kHeightPx);
  std::fill(d.pixels().begin(), d.pixels().end(), static_cast<uint16_t>(depth_m * 1000.0f));
  return d;
}

RaycastParams ray_params() {
  RaycastParams ray;
  ray.k = kK;
  ray.step_m = kSizeM / kRes;
  return ray;
}

/// One untracked frame: fused into the selected map when `fuse`, then raycast and rendered.
void run_frame(Backend& b, const HostImage<uint16_t>& depth, bool fuse) {
  BilateralParams pre;
  for (int i = 0; i < 5; ++i) pre.spatial_weight[i] = std::exp(-((i - 2) * (i - 2)) / 32.0f);
  PyramidParams pyr;
  for (int l = 0; l < kMaxPyramidLevels; ++l) {
    pyr.level_intrinsics[l] = kK.scaled_down(static_cast<float>(1 << l));
  }
  IntegrateParams integ;
  integ.k = kK;
  RenderParams render;
  render.tracked_this_frame = false;
  render.volume_ray = ray_params();
  b.upload_depth(depth.view());
  b.begin_frame(fuse ? kFuseShape : kLookShape);
  b.preprocess(pre);
  b.build_pyramid(pyr);
  b.skip_tracking();
  b.allocate_blocks(integ, fuse);
  b.integrate(integ, fuse);
  b.raycast(ray_params());
  b.render(render);
  b.end_frame();
  b.read_state();
}

/// Raycast vertices of the central pixels that hit a surface, and how many of them lie on the
/// wall at `depth_m` (their z: the camera sits at z = 0 without rotation).
struct Hits {
  int hit = 0;
  int on_wall = 0;
};
Hits raycast_hits(Backend& b, float depth_m) {
  const DebugMaps maps = b.read_maps();
  Hits h;
  for (int y = kHeightPx / 4; y < 3 * kHeightPx / 4; ++y) {
    for (int x = kWidthPx / 4; x < 3 * kWidthPx / 4; ++x) {
      const Vec3f v = maps.ref_vertex(x, y);
      if (v.x == 0.0f && v.y == 0.0f && v.z == 0.0f) continue;
      ++h.hit;
      if (std::fabs(v.z - depth_m) < kSurfaceTolM) ++h.on_wall;
    }
  }
  return h;
}

/// How many of a mesh's vertices lie on the wall at `depth_m`. Not every vertex does: where the
/// frustum's sides cut the truncation band, the fused voxels meet empty ones, within a band's
/// width (mu, 0.1 m) of the wall; the walls lie further apart than that.
int vertices_on_wall(const Mesh& mesh, float depth_m) {
  int n = 0;
  for (const MeshVertex& v : mesh.vertices) n += std::fabs(v.p_m.z - depth_m) < kSurfaceTolM;
  return n;
}

bool same_pixels(const HostImage<Rgba8>& a, const HostImage<Rgba8>& b) {
  return a.pixels().size() == b.pixels().size() &&
         std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(Rgba8)) == 0;
}

bool same_bytes(const Mesh& a, const Mesh& b) {
  return a.vertices.size() == b.vertices.size() && a.triangles.size() == b.triangles.size() &&
         std::memcmp(a.vertices.data(), b.vertices.data(),
                     a.vertices.size() * sizeof(MeshVertex)) == 0 &&
         std::memcmp(a.triangles.data(), b.triangles.data(),
                     a.triangles.size() * sizeof(MeshTriangle)) == 0;
}

using BackendMaps = test::BackendMapTest;

TEST_P(BackendMaps, EachMapHoldsOnlyWhatWasFusedIntoIt) {
  auto b = make_backend(GetParam().backend_kind(), setup_for(GetParam().map_kind()));
  b->reset(Mat4f::translation({kSizeM / 2, kSizeM / 2, 0.0f}));
  EXPECT_EQ(b->map_count(), 1);
  EXPECT_EQ(b->selected_map(), 0);

  // Map 0: the near wall; then a frame that only looks, so both shapes are recorded on map 0.
  run_frame(*b, wall_mm(kNearWallM), true);
  run_frame(*b, wall_mm(kNearWallM), false);
  const Mesh first(b->extract_mesh());
  const HostImage<Rgba8> first_render = b->read_renders().volume;
  ASSERT_GT(first.vertices.size(), 100u);
  EXPECT_GT(vertices_on_wall(first, kNearWallM), static_cast<int>(first.vertices.size()) / 2);
  EXPECT_EQ(vertices_on_wall(first, kFarWallM), 0);

  // Map 1: created empty and not selected; once selected, the same frame shapes fuse the far
  // wall into it.
  const int second = b->create_map();
  EXPECT_EQ(second, 1);
  EXPECT_EQ(b->map_count(), 2);
  EXPECT_EQ(b->selected_map(), 0);
  b->select_map(second);
  EXPECT_EQ(b->extract_mesh().vertex_count, 0u) << "a new map starts empty";
  run_frame(*b, wall_mm(kFarWallM), true);
  run_frame(*b, wall_mm(kFarWallM), false);
  const Hits far_hits = raycast_hits(*b, kFarWallM);
  EXPECT_GT(far_hits.hit, kWidthPx * kHeightPx / 8);
  EXPECT_EQ(far_hits.on_wall, far_hits.hit) << "map 1 raycasts only the far wall";
  const Mesh far(b->extract_mesh());
  ASSERT_GT(far.vertices.size(), 100u);
  EXPECT_GT(vertices_on_wall(far, kFarWallM), static_cast<int>(far.vertices.size()) / 2);
  EXPECT_EQ(vertices_on_wall(far, kNearWallM), 0) << "map 1 meshes only the far wall";
  EXPECT_FALSE(same_pixels(b->read_renders().volume, first_render));

  // Back to map 0: untouched by everything done to map 1, and every stage sees it again.
  b->select_map(0);
  EXPECT_TRUE(same_bytes(Mesh(b->extract_mesh()), first)) << "map 0 changed while map 1 was used";
  run_frame(*b, wall_mm(kFarWallM), false);  // looks only: the far wall's depth is not fused
  const Hits near_hits = raycast_hits(*b, kNearWallM);
  EXPECT_GT(near_hits.hit, kWidthPx * kHeightPx / 8);
  EXPECT_EQ(near_hits.on_wall, near_hits.hit) << "map 0 raycasts only the near wall";
  EXPECT_TRUE(same_pixels(b->read_renders().volume, first_render));
  EXPECT_TRUE(same_bytes(Mesh(b->extract_mesh()), first));

  // And map 1 kept its wall meanwhile.
  b->select_map(second);
  EXPECT_TRUE(same_bytes(Mesh(b->extract_mesh()), far));
}

TEST_P(BackendMaps, ReadAndUploadActOnTheSelectedMap) {
  auto b = make_backend(GetParam().backend_kind(), setup_for(GetParam().map_kind()));
  b->reset(Mat4f::translation({kSizeM / 2, kSizeM / 2, 0.0f}));
  run_frame(*b, wall_mm(kNearWallM), true);
  const Mesh first(b->extract_mesh());
  const int second = b->create_map();
  b->select_map(second);
  // Map 0's contents copied into map 1 through the selected map's read and upload calls.
  b->select_map(0);
  if (GetParam().blocks()) {
    const BlockMapContents blocks = b->read_blocks();
    b->select_map(second);
    b->upload_blocks(blocks);
  } else {
    const std::vector<Voxel> voxels = b->read_volume();
    b->select_map(second);
    b->upload_volume(voxels);
  }
  EXPECT_TRUE(same_bytes(Mesh(b->extract_mesh()), first));
  // reset() empties the selected map only.
  b->reset(Mat4f::translation({kSizeM / 2, kSizeM / 2, 0.0f}));
  EXPECT_EQ(b->extract_mesh().vertex_count, 0u);
  b->select_map(0);
  EXPECT_TRUE(same_bytes(Mesh(b->extract_mesh()), first));
}

TEST_P(BackendMaps, AMapThatDoesNotExistOrACallInsideAFrameIsAnError) {
  auto b = make_backend(GetParam().backend_kind(), setup_for(GetParam().map_kind()));
  b->reset(Mat4f::translation({kSizeM / 2, kSizeM / 2, 0.0f}));
  EXPECT_THROW(b->select_map(1), Error);
  EXPECT_THROW(b->select_map(-1), Error);
  EXPECT_EQ(b->selected_map(), 0);
  const HostImage<uint16_t> depth = wall_mm(kNearWallM);
  b->upload_depth(depth.view());
  b->begin_frame(kLookShape);
  EXPECT_THROW(b->create_map(), Error);
  EXPECT_THROW(b->select_map(0), Error);
  b->end_frame();
  b->read_state();
  EXPECT_EQ(b->map_count(), 1);
  EXPECT_EQ(b->create_map(), 1);
  EXPECT_NO_THROW(b->select_map(1));
}

KFX_INSTANTIATE_BACKEND_MAP_TESTS(BackendMaps);

TEST(BackendMapMemory, AnotherMapCostsTheFirstsBudgetAndAMapThatDoesNotFitSaysSo) {
  const BackendSetup dense = setup_for(MapKind::kDense);
  EXPECT_EQ(map_bytes(dense), static_cast<uint64_t>(kRes) * kRes * kRes * sizeof(Voxel));
  BackendSetup blocks = setup_for(MapKind::kBlocks);
  const uint64_t one_budget = map_bytes(blocks);
  blocks.block_capacity *= 2;
  EXPECT_GT(map_bytes(blocks), one_budget) << "each map holds the whole block budget";
  EXPECT_NO_THROW(check_another_map_fits(dense, 1, map_bytes(dense), "free GPU memory"));
  EXPECT_NO_THROW(check_another_map_fits(dense, 1, 0, "free GPU memory"));  // 0: unknown
  try {
    check_another_map_fits(blocks, 2, map_bytes(blocks) - 1, "free GPU memory");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("another map"), std::string::npos) << message;
    EXPECT_NE(message.find("holds 2 maps"), std::string::npos) << message;
    EXPECT_NE(message.find("free GPU memory"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace kfx
