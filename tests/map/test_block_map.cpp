/// The block map (volume=blocks, map/ and the block paths of the CPU backend): its allocation
/// covers every voxel the dense cube changes, and where both fit it gives the dense run's
/// trajectory and mesh; it repeats bit for bit, reaches outside any cube and reports a full
/// budget. The CUDA backend's block map: tests/backend/test_block_map_cuda.cpp.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "backend/backend.hpp"
#include "eval/report.hpp"
#include "io/reader.hpp"
#include "kernels/block_allocation.hpp"
#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"
#include "map/host_block_map.hpp"
#include "pipeline/pipeline.hpp"
#include "support/mesh_test_support.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

// The "same answers where both fit": per-frame positions (relative to the first frame)
// within a median of 0.1 mm, meshes within one voxel (Hausdorff).
constexpr double kSameTrajectoryMedian_m = 1e-4;

/// A run's trajectory, per-frame reports and final mesh.
struct MapRun {
  std::vector<io::StampedPose> trajectory;
  std::vector<io::StampedPose> ground_truth;
  std::vector<FrameReport> reports;
  Mesh mesh;
};

MapRun run_map(const std::string& input, const PipelineConfig& config, int frames) {
  auto reader = io::open_reader(input);
  const auto& k = config.input.camera_px;
  const Intrinsics intrinsics = (k[0] != 0 || k[1] != 0) ? Intrinsics{k[0], k[1], k[2], k[3]}
                                                         : reader->default_intrinsics().value();
  Pipeline pipeline(config, intrinsics, reader->width_px(), reader->height_px(), BackendKind::kCpu);
  MapRun run;
  run.ground_truth = reader->ground_truth();
  io::Frame frame;
  for (int f = 0; f < frames && reader->next(frame).status == io::ReadStatus::kOk; ++f) {
    run.reports.push_back(pipeline.process(frame.depth_mm));
    run.trajectory.push_back(io::to_stamped_pose(frame.stamp_s, run.reports.back().T_world_cam));
  }
  run.mesh = Mesh(pipeline.backend().extract_mesh());
  return run;
}

PipelineConfig with_blocks(PipelineConfig config) {
  set_config_value(config, "volume", "blocks");
  return config;
}

// Meshes, compared inside the cube (2 voxels from its faces: the block map also meshes what lies
// beyond them). A block map stores no free space outside its blocks, so where a frame first
// reaches a block, voxels that the cube had already seen empty (weight > 0, tsdf +1) take the
// new measurement alone; a noisy one then leaves a fleck of surface the cube averaged away (and
// the reverse). Measured: 0.005-0.012 % of the vertices beyond a voxel on the synthetic room,
// up to 0.5 % on TUM fr1_xyz's real Kinect depth (flying pixels at edges); at most this share may
// lie beyond a voxel of the other mesh.
constexpr double kMaxShareBeyondVoxel = 1e-2;
/// Distance inside the cube's faces below which mesh vertices are left out of the comparison.
constexpr double kFaceMarginVox = 2.0;

/// Distance from one mesh's vertices to the other's.
struct MeshDistance {
  double max_m = 0;               ///< the directed Hausdorff distance (over vertices)
  double share_beyond_voxel = 0;  ///< share of vertices farther than a voxel
};

MeshDistance mesh_distance(const Mesh& from, const Mesh& to, double voxel_m, double cube_m) {
  const test::PointGrid grid(test::positions(to), 4 * voxel_m);
  MeshDistance d;
  int beyond = 0, compared = 0;
  const double lo = kFaceMarginVox * voxel_m, hi = cube_m - lo;
  for (const auto& v : from.vertices) {
    const Vec3f p = v.p_m;
    if (p.x < lo || p.y < lo || p.z < lo || p.x > hi || p.y > hi || p.z > hi) continue;
    ++compared;
    const double m = grid.nearest_m(v.p_m);
    d.max_m = std::max(d.max_m, m);
    beyond += m > voxel_m ? 1 : 0;
  }
  d.share_beyond_voxel = compared == 0 ? 1.0 : double(beyond) / compared;
  return d;
}

/// Expects the block map to give the dense run's answers on `input`'s first `frames` frames.
void expect_same_as_dense(const std::string& input, const PipelineConfig& dense, int frames) {
  const MapRun d = run_map(input, dense, frames);
  const MapRun b = run_map(input, with_blocks(dense), frames);
  ASSERT_EQ(d.trajectory.size(), b.trajectory.size());
  int tracked_d = 0, tracked_b = 0;
  for (size_t i = 0; i < d.reports.size(); ++i) {
    tracked_d += d.reports[i].tracked;
    tracked_b += b.reports[i].tracked;
    EXPECT_EQ(b.reports[i].map_blocks_dropped, 0) << "frame " << i;
  }
  EXPECT_EQ(tracked_b, tracked_d);
  const auto [median_m, max_m] = test::relative_position_difference(d.trajectory, b.trajectory);
  EXPECT_LE(median_m, kSameTrajectoryMedian_m) << input << " (max " << max_m * 1e3 << " mm)";
  const double voxel_m = dense.volume.size_m / dense.volume.resolution_vox;
  ASSERT_GT(d.mesh.vertices.size(), 1000u);
  ASSERT_GT(b.mesh.vertices.size(), 1000u);
  const double cube_m = dense.volume.size_m;
  const MeshDistance to_dense = mesh_distance(b.mesh, d.mesh, voxel_m, cube_m);
  const MeshDistance to_blocks = mesh_distance(d.mesh, b.mesh, voxel_m, cube_m);
  for (const MeshDistance& m : {to_dense, to_blocks}) {
    EXPECT_LE(m.share_beyond_voxel, kMaxShareBeyondVoxel) << input;
  }
  std::cout << input << ": " << tracked_b << "/" << b.reports.size() << " tracked, position "
            << "difference to the dense cube median " << median_m * 1e3 << " mm, max "
            << max_m * 1e3 << " mm; mesh Hausdorff " << to_dense.max_m * 1e3 << " / "
            << to_blocks.max_m * 1e3 << " mm, vertices beyond a voxel "
            << to_dense.share_beyond_voxel * 100 << " / " << to_blocks.share_beyond_voxel * 100
            << " % (voxel " << voxel_m * 1e3 << " mm); " << b.reports.back().map_blocks
            << " blocks\n";
}

// --- Kernel level: allocation and integration against the dense cube ---------------------------

/// A depth image of a tilted plane with a bump, some holes and noise (metres).
HostImage<float> test_depth(int w, int h) {
  HostImage<float> depth(w, h);
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.0f, 0.004f);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float u = (x - w / 2.0f) / w, v = (y - h / 2.0f) / h;
      float d = 1.4f + 0.8f * u + 0.3f * v + 0.25f * std::exp(-40.0f * (u * u + v * v));
      if ((x * 7 + y * 3) % 23 == 0) d = 0.0f;  // holes
      depth(x, y) = d > 0.0f ? d + noise(rng) : 0.0f;
    }
  }
  return depth;
}

// The block and the cube compute a voxel's position with the same float operations, but GCC
// contracts a·b + c into FMAs differently where it inlines the same body into different loops
// (CMakeLists.txt), which can move a stored tsdf by a unit or two (1 unit = 3e-5 of mu).
constexpr int kContractionUnits = 4;

/// A smooth colour image (neighbouring pixels differ by at most 3 units per channel), so a
/// voxel whose position the cube and the block compute a rounding apart, and which then picks
/// the neighbouring pixel, differs by little.
HostImage<Rgb8> test_colour(int w, int h) {
  HostImage<Rgb8> rgb(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      rgb(x, y) = Rgb8{static_cast<uint8_t>(3 * x), static_cast<uint8_t>(3 * y),
                       static_cast<uint8_t>(x + y)};
    }
  }
  return rgb;
}

/// Colour stored units (kColourScale per 8-bit unit) by which a neighbouring pixel may differ.
constexpr int kNeighbourPixelColourUnits = 3 * static_cast<int>(kColourScale) + 1;

TEST(BlockMap, AllocationCoversEveryVoxelTheCubeChangesAndIntegratesTheSameValues) {
  const int w = 80, h = 60, res = 128;
  const float size_m = 3.2f;
  const Intrinsics k{68.0f, 68.0f, 39.5f, 29.5f};
  const HostImage<float> depth = test_depth(w, h);
  const HostImage<Rgb8> rgb = test_colour(w, h);
  for (const float yaw : {0.0f, 0.6f}) {
    Mat4f pose = Mat4f::translation(Vec3f{1.6f, 1.5f, 0.1f});  // turned by `yaw` about y
    pose.m[0][0] = pose.m[2][2] = std::cos(yaw);
    pose.m[0][2] = std::sin(yaw);
    pose.m[2][0] = -std::sin(yaw);
    TrackingState state = initial_tracking_state(pose);
    state.max_depth_m = 0.0f;
    for (float d : depth.pixels()) state.max_depth_m = std::max(state.max_depth_m, d);
    prepare_integration(state, true);
    IntegrateParams p;
    p.k = k;
    p.mu_m = 0.1f;
    p.colour_camera.k = k;  // registered colour, as ICL-NUIM's and TUM's
    // The dense cube, integrated row by row as the CPU backend does, with its colour field.
    std::vector<Voxel> cube(static_cast<size_t>(res) * res * res, empty_voxel());
    std::vector<ColourVoxel> cube_colour(cube.size(), ColourVoxel{0, 0, 0, 0});
    const IntegrateArgs dense{p,
                              VolumeView{cube.data(), res, size_m},
                              depth.view(),
                              &state,
                              ImageView<const Vec3f>{},
                              ColourVolumeView{cube_colour.data(), res, size_m},
                              rgb.view()};
    for (int z = 0; z < res; ++z) {
      for (int y = 0; y < res; ++y) integrate_row(y, z, dense);
    }
    // The block map (with colour): allocate the band, integrate the blocks in view.
    HostBlockMap map(40000, res, size_m, true);
    std::vector<uint64_t> candidates;
    const BlockAllocArgs alloc{k, p.mu_m, map.view(), depth.view(), &state};
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        band_blocks_of_pixel(x, y, alloc, [&](uint64_t key) { candidates.push_back(key); });
      }
    }
    EXPECT_EQ(map.allocate(candidates).dropped, 0);
    const BlockMapView view = map.view();
    IntegrateArgsT<OneBlockView> a{p,         OneBlockView{},           depth.view(),
                                   &state,    ImageView<const Vec3f>{}, ColourVolumeView{},
                                   rgb.view()};
    for (int b = 0; b < view.block_count; ++b) {
      if (!block_in_view(view, b, a)) continue;
      a.volume = one_block_view(view, b);
      integrate_block(a);
    }
    // Every voxel the frame moved below +1 is in the map, with the same bits; every stored voxel
    // inside the cube equals the cube's, and so does its colour.
    int changed = 0, worst = 0, coloured = 0;
    for (int z = 0; z < res; ++z) {
      for (int y = 0; y < res; ++y) {
        for (int x = 0; x < res; ++x) {
          const Voxel c = cube[x + y * res + static_cast<size_t>(z) * res * res];
          const Voxel m = view.voxel(x, y, z);
          if (c.weight > 0 && c.tsdf < static_cast<int16_t>(kTsdfScale)) {
            ++changed;
            ASSERT_GE(view.block_of(x, y, z), 0) << "voxel " << x << "," << y << "," << z;
          }
          if (m.weight > 0 || c.tsdf < static_cast<int16_t>(kTsdfScale)) {
            ASSERT_NEAR(m.tsdf, c.tsdf, kContractionUnits) << "voxel " << x << "," << y << "," << z;
            ASSERT_EQ(m.weight, c.weight) << "voxel " << x << "," << y << "," << z;
            worst = std::max(worst, std::abs(m.tsdf - c.tsdf));
          }
          const ColourVoxel cc = cube_colour[x + y * res + static_cast<size_t>(z) * res * res];
          const ColourVoxel mc = map_colour_voxel(view, x, y, z);
          ASSERT_EQ(mc.weight, cc.weight) << "colour of voxel " << x << "," << y << "," << z;
          ASSERT_NEAR(mc.r, cc.r, kNeighbourPixelColourUnits) << x << "," << y << "," << z;
          ASSERT_NEAR(mc.g, cc.g, kNeighbourPixelColourUnits) << x << "," << y << "," << z;
          ASSERT_NEAR(mc.b, cc.b, kNeighbourPixelColourUnits) << x << "," << y << "," << z;
          coloured += cc.weight > 0;
        }
      }
    }
    EXPECT_GT(changed, 10000) << "the test frame should reach many voxels";
    EXPECT_GT(coloured, 10000) << "the band should take colour";
    std::cout << "yaw " << yaw << ": " << changed << " voxels changed, " << map.block_count()
              << " blocks, largest tsdf difference " << worst << " stored units\n";
    EXPECT_LT(map.block_count(), res * res * res / kBlockVoxels / 4) << "blocks only near depth";
  }
}

// --- Pipeline level --------------------------------------------------------------------------

PipelineConfig synthetic_config(const std::string& input) {
  auto reader = io::open_reader(input);
  return test::input_config(*reader);
}

// The room's first 24 frames (20 tracked after the bootstrap frames): the dense cube's
// integration of every voxel is most of the time, and the answers are the same frame by frame.
TEST(BlockMap, SameTrajectoryAndMeshAsTheDenseCubeOnTheSyntheticRoom) {
  const std::string input = "synthetic:frames=24,width=160,height=120";
  expect_same_as_dense(input, synthetic_config(input), 24);
}

TEST(BlockMap, SameTrajectoryAndMeshAsTheDenseCubeWithTheNormalsNoiseSpan) {
  // raycast_normal_span_noise reads its wide differences through the block map's reader as the
  // cube's through its array: the same answers.
  const std::string input = "synthetic:frames=24,width=160,height=120";
  PipelineConfig config = synthetic_config(input);
  set_config_value(config, "raycast_normal_span_noise", "2.5");
  expect_same_as_dense(input, config, 24);
}

TEST(BlockMap, SameTrajectoryAndMeshAsTheDenseCubeOnIclOffice) {
  if (!test::shared_exists("data/icl_office_kt0")) GTEST_SKIP() << "needs ../shared/data";
  PipelineConfig c;  // SLAMBench's ICL-NUIM setting at 320x240
  set_config_value(c, "camera", "481.2,480,320,240");
  set_config_value(c, "volume_size_m", "5");
  set_config_value(c, "integration_rate", "1");
  expect_same_as_dense(test::shared_path("data/icl_office_kt0"), c, 60);
}

TEST(BlockMap, SameTrajectoryAndMeshAsTheDenseCubeOnTumFr1Xyz) {
  if (!test::shared_exists("data/tum_fr1_xyz")) GTEST_SKIP() << "needs ../shared/data";
  PipelineConfig c;
  set_config_value(c, "volume_size_m", "4");
  set_config_value(c, "integration_rate", "1");
  expect_same_as_dense(test::shared_path("data/tum_fr1_xyz"), c, 60);
}

TEST(BlockMap, AReloadedMapMeshesToTheSameBytes) {
  // The map's contents in key order are all a mesh depends on: a fresh backend given them
  // (as `kfx mesh` gives it a saved map) meshes to the same bytes, however large its capacity.
  const std::string input = "synthetic:frames=12,width=160,height=120";
  const PipelineConfig c = with_blocks(synthetic_config(input));
  auto reader = io::open_reader(input);
  Pipeline pipeline(c, reader->default_intrinsics().value(), reader->width_px(),
                    reader->height_px(), BackendKind::kCpu);
  io::Frame frame;
  while (reader->next(frame).status == io::ReadStatus::kOk) pipeline.process(frame.depth_mm);
  const Mesh live(pipeline.backend().extract_mesh());
  const BlockMapContents contents = pipeline.backend().read_blocks();
  EXPECT_TRUE(std::is_sorted(contents.keys.begin(), contents.keys.end()));
  BackendSetup setup;
  setup.input_width_px = setup.input_height_px = 8;
  setup.compute_ratio = setup.pyramid_levels = 1;
  setup.map_kind = MapKind::kBlocks;
  setup.volume_res_vox = contents.grid_res;
  setup.volume_size_m = contents.grid_size_m;
  setup.block_capacity = static_cast<uint32_t>(contents.keys.size()) + 777;
  auto backend = make_backend(BackendKind::kCpu, setup);
  backend->upload_blocks(contents);
  const Mesh again(backend->extract_mesh());
  ASSERT_GT(live.triangles.size(), 1000u);
  ASSERT_EQ(again.vertices.size(), live.vertices.size());
  ASSERT_EQ(again.triangles.size(), live.triangles.size());
  EXPECT_EQ(0, std::memcmp(again.vertices.data(), live.vertices.data(),
                           live.vertices.size() * sizeof(MeshVertex)));
  EXPECT_EQ(0, std::memcmp(again.triangles.data(), live.triangles.data(),
                           live.triangles.size() * sizeof(MeshTriangle)));
}

TEST(BlockMap, RepeatsBitForBit) {
  const std::string input = "synthetic:frames=20,width=160,height=120";
  const PipelineConfig c = with_blocks(synthetic_config(input));
  const MapRun a = run_map(input, c, 20), b = run_map(input, c, 20);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    for (int j = 0; j < 3; ++j) EXPECT_EQ(a.trajectory[i].t[j], b.trajectory[i].t[j]);
  }
  ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size());
  ASSERT_EQ(a.mesh.triangles.size(), b.mesh.triangles.size());
  EXPECT_EQ(0, std::memcmp(a.mesh.vertices.data(), b.mesh.vertices.data(),
                           a.mesh.vertices.size() * sizeof(MeshVertex)));
  EXPECT_EQ(0, std::memcmp(a.mesh.triangles.data(), b.mesh.triangles.data(),
                           a.mesh.triangles.size() * sizeof(MeshTriangle)));
}

TEST(BlockMap, MapsOutsideAnyCubeWithTheFirstCameraAtTheOrigin) {
  // The first camera at the origin: a dense cube would hold only the scene's positive octant;
  // blocks take negative coordinates as well.
  const std::string input = "synthetic:frames=40,width=160,height=120";
  PipelineConfig c = with_blocks(synthetic_config(input));
  set_config_value(c, "init_pose_factor", "0,0,0");
  set_config_value(c, "voxel_size_m", "0.02");
  const MapRun run = run_map(input, c, 40);
  int tracked = 0;
  for (const auto& r : run.reports) tracked += r.tracked;
  EXPECT_EQ(tracked, 36);  // every frame after the 4 bootstrap frames
  const auto ate = eval::evaluate_trajectories(run.trajectory, run.ground_truth, {});
  EXPECT_LT(ate.ate.stats_m.rmse, 0.01);
  float min_coord = 0.0f;
  for (const auto& v : run.mesh.vertices) min_coord = std::min({min_coord, v.p_m.x, v.p_m.y});
  EXPECT_LT(min_coord, -0.5f) << "the mesh should reach negative coordinates";
}

TEST(BlockMap, AFullBudgetIsReportedPerFrameNotSilent) {
  const std::string input = "synthetic:frames=8,width=160,height=120";
  PipelineConfig c = with_blocks(synthetic_config(input));
  set_config_value(c, "map_budget_mb", "1");
  const MapRun run = run_map(input, c, 8);
  const int capacity = static_cast<int>(block_capacity_for_budget(1 << 20));
  EXPECT_GT(run.reports.front().map_blocks_dropped, 0);
  for (const auto& r : run.reports) EXPECT_EQ(r.map_blocks, capacity);
}

}  // namespace
}  // namespace kfx
