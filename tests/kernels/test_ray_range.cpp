/// The raycast's per-tile depth ranges (kernels/ray_range.hpp, setting raycast_tile_bounds):
/// a block's footprint holds every point a march sample reading one of its voxels can be at,
/// and a block-map run gives the same reference maps bit for bit with the ranges and without,
/// on the CPU and (where a GPU exists) on CUDA.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "backend/backend.hpp"
#include "core/se3.hpp"
#include "io/reader.hpp"
#include "kernels/ray_range.hpp"
#include "pipeline/pipeline.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

/// A map of one touched block at block coordinates `c`, voxels `voxel_m` wide.
struct OneBlockMap {
  uint64_t key;
  uint8_t touched = 1;
  BlockMapView view;
  OneBlockMap(Vec3i c, float voxel_m) : key(pack_block_key(c.x, c.y, c.z)) {
    view.block_keys = &key;
    view.block_touched = &touched;
    view.block_count = 1;
    view.grid_res = 1;
    view.grid_size_m = voxel_m;
  }
};

TEST(RayRange, AFootprintHoldsEveryPointThatReadsTheBlock) {
  // Points within a voxel (per axis) of the block's voxel centres are the points whose
  // samples may read one of its voxels. Each one in front of the camera, between near and far
  // and inside the image must lie in a footprint tile at a depth inside the footprint's range.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  RayRangeArgs a;
  a.k = Intrinsics{258.65f, 258.25f, 159.3f, 127.65f};
  a.width_px = 320;
  a.height_px = 240;
  a.near_m = 0.4f;
  a.far_m = 4.0f;
  a.tiles.tiles_x = ray_range_tiles_for(a.width_px);
  a.tiles.tiles_y = ray_range_tiles_for(a.height_px);
  int checked = 0, near_edge = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const float voxel_m = trial % 2 ? 0.005f : 0.02f;
    // A pose turned about every axis, and a block somewhere within ~3 m of it.
    const double twist[6] = {unit(rng),       unit(rng),       unit(rng),
                             unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5};
    const Mat4f T_world_cam = se3_exp(twist);
    const Mat4f T_cam_world = rigid_inverse(T_world_cam);
    const Vec3f ahead = T_world_cam * Vec3f{(unit(rng) - 0.5f) * 3, (unit(rng) - 0.5f) * 2,
                                            unit(rng) * 4.2f - 0.1f};
    const float block_m = kBlockSide * voxel_m;
    const Vec3i c{static_cast<int>(std::floor(ahead.x / block_m)),
                  static_cast<int>(std::floor(ahead.y / block_m)),
                  static_cast<int>(std::floor(ahead.z / block_m))};
    OneBlockMap map(c, voxel_m);
    RayRangeFootprint f;
    const bool any = block_ray_footprint(map.view, 0, T_cam_world, a, f);
    for (int s = 0; s < 64; ++s) {
      // Voxel-centre coordinates c·8 − 1 … c·8 + 8 (a voxel around the block's centres).
      const float gx = c.x * kBlockSide - 1 + unit(rng) * (kBlockSide + 1);
      const float gy = c.y * kBlockSide - 1 + unit(rng) * (kBlockSide + 1);
      const float gz = c.z * kBlockSide - 1 + unit(rng) * (kBlockSide + 1);
      const Vec3f p_world{(gx + 0.5f) * voxel_m, (gy + 0.5f) * voxel_m, (gz + 0.5f) * voxel_m};
      const Vec3f p = T_cam_world * p_world;
      if (p.z < a.near_m || p.z > a.far_m) continue;
      const float u = a.k.fx * p.x / p.z + a.k.cx, v = a.k.fy * p.y / p.z + a.k.cy;
      if (u < 0 || v < 0 || u > a.width_px - 1 || v > a.height_px - 1) continue;
      ++checked;
      ASSERT_TRUE(any) << "trial " << trial;
      const int tx = static_cast<int>(u) / kRayRangeTilePx;
      const int ty = static_cast<int>(v) / kRayRangeTilePx;
      EXPECT_GE(tx, f.tile_x0) << "trial " << trial;
      EXPECT_LE(tx, f.tile_x1) << "trial " << trial;
      EXPECT_GE(ty, f.tile_y0) << "trial " << trial;
      EXPECT_LE(ty, f.tile_y1) << "trial " << trial;
      EXPECT_GE(p.z, f.near_m) << "trial " << trial;
      EXPECT_LE(p.z, f.far_m) << "trial " << trial;
      if (p.z - f.near_m < voxel_m * 3.0f) ++near_edge;
    }
    // An untouched block has no footprint.
    map.touched = 0;
    EXPECT_FALSE(block_ray_footprint(map.view, 0, T_cam_world, a, f));
  }
  EXPECT_GT(checked, 20000);
  // The ranges are tight: many points lie within three voxels of the near bound.
  EXPECT_GT(near_edge, 100);
}

/// Every frame's reference vertex and normal maps of a block-map run of `input` on `backend`.
struct ReferenceMaps {
  std::vector<HostImage<Vec3f>> vertex, normal;
  int tracked = 0;
};
ReferenceMaps reference_maps(const std::string& input, PipelineConfig config, bool tile_bounds,
                             BackendKind backend, int frames) {
  set_config_value(config, "volume", "blocks");
  set_config_value(config, "raycast_tile_bounds", tile_bounds ? "on" : "off");
  auto reader = io::open_reader(input);
  Pipeline pipeline(config, reader->default_intrinsics().value(), reader->width_px(),
                    reader->height_px(), backend);
  ReferenceMaps maps;
  io::Frame frame;
  for (int f = 0; f < frames && reader->next(frame).status == io::ReadStatus::kOk; ++f) {
    maps.tracked += pipeline.process(frame.depth_mm).tracked ? 1 : 0;
    DebugMaps m = pipeline.backend().read_maps();
    maps.vertex.push_back(std::move(m.ref_vertex));
    maps.normal.push_back(std::move(m.ref_normal));
  }
  return maps;
}

bool same_bits(const HostImage<Vec3f>& a, const HostImage<Vec3f>& b) {
  return a.width() == b.width() && a.height() == b.height() &&
         std::memcmp(a.data(), b.data(), sizeof(Vec3f) * a.width() * a.height()) == 0;
}

/// Runs `input` with and without the ranges and expects the same maps bit for bit, frame by
/// frame, under the march settings `sets` (key=value).
void expect_same_maps(const std::string& input, const std::vector<std::string>& sets,
                      BackendKind backend, int frames) {
  auto reader = io::open_reader(input);
  PipelineConfig config = test::input_config(*reader);
  for (const auto& s : sets) set_config_assignment(config, s);
  const ReferenceMaps with = reference_maps(input, config, true, backend, frames);
  const ReferenceMaps without = reference_maps(input, config, false, backend, frames);
  ASSERT_EQ(with.vertex.size(), static_cast<size_t>(frames));
  ASSERT_EQ(without.vertex.size(), with.vertex.size());
  EXPECT_GT(with.tracked, frames / 4);
  EXPECT_EQ(with.tracked, without.tracked);
  int hits = 0;
  for (size_t f = 0; f < with.vertex.size(); ++f) {
    EXPECT_TRUE(same_bits(with.vertex[f], without.vertex[f])) << "frame " << f;
    EXPECT_TRUE(same_bits(with.normal[f], without.normal[f])) << "frame " << f;
    const HostImage<Vec3f>& v = with.vertex[f];
    for (int y = 0; y < v.height(); ++y) {
      for (int x = 0; x < v.width(); ++x) hits += v(x, y).z != 0.0f ? 1 : 0;
    }
  }
  // The maps compared are real ones: most rays hit the room.
  EXPECT_GT(hits, static_cast<int>(with.vertex.size()) * with.vertex[0].width() *
                      with.vertex[0].height() / 2);
}

// A fast camera with a 90° turn and blank frames: the view changes a lot between raycasts.
const std::string kHardInput = "synthetic:frames=48,width=160,height=120,speed=3,jump=20-23";

/// expect_same_maps under exact's march at the room's voxels and at 1 cm, and under the march's
/// approximations (constant step, two-value samples, one ray per 2 × 2 pixels; the tsdf step).
void expect_same_maps_under_every_march(BackendKind backend) {
  expect_same_maps(kHardInput, {}, backend, 48);
  expect_same_maps(kHardInput, {"voxel_size_m=0.01"}, backend, 24);
  expect_same_maps(kHardInput, {"voxel_size_m=0.01", "raycast_step=tsdf"}, backend, 12);
  expect_same_maps(
      kHardInput,
      {"raycast_constant_step_m=0.05", "raycast_interp=two_value", "raycast_block_px=2,2"}, backend,
      24);
}

TEST(RayRange, TheSameReferenceMapsWithAndWithoutTheRangesOnTheCpu) {
  expect_same_maps_under_every_march(BackendKind::kCpu);
}

TEST(RayRange, TheSameReferenceMapsWithAndWithoutTheRangesOnCuda) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  expect_same_maps_under_every_march(BackendKind::kCuda);
}

}  // namespace
}  // namespace kfx
