// Tests of the large synthetic scene (synthetic:scene=house, io/synthetic_house.hpp): its floor
// plan and path, views a tracker can follow, ground truth consistent with the rendered depth,
// the true surface used for evaluation, and a short block-map run on it.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/platform.hpp"
#include "eval/ate.hpp"
#include "io/synthetic.hpp"
#include "io/synthetic_house.hpp"
#include "io/synthetic_scene.hpp"
#include "pipeline/config.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx::io {
namespace {

using synth::Vec3d;

SyntheticScene house(const std::string& extra = "") {
  return SyntheticScene(parse_synthetic_spec("synthetic:scene=house" + extra));
}

/// A scene point seen through pixel (x, y) at depth z (metres) from the pose [R | t].
Vec3d back_project(const double R[3][3], const double t[3], double f, double cx, double cy,
                   double x, double y, double z) {
  const double c[3] = {(x - cx) / f * z, (y - cy) / f * z, z};
  return {R[0][0] * c[0] + R[0][1] * c[1] + R[0][2] * c[2] + t[0],
          R[1][0] * c[0] + R[1][1] * c[1] + R[1][2] * c[2] + t[1],
          R[2][0] * c[0] + R[2][1] * c[1] + R[2][2] * c[2] + t[2]};
}

TEST(SyntheticHouse, SpecDefaultsDescriptionAndSettings) {
  const SyntheticOptions o = parse_synthetic_spec("synthetic:scene=house");
  EXPECT_EQ(o.scene, synth::SceneLayout::kHouse);
  // One loop of the path by default: its length at 0.2 m/s, 30 frames a second.
  EXPECT_EQ(o.frames, SyntheticScene::house_loop_frames(1.0));
  EXPECT_NEAR(o.frames, synth::HousePath().length_m() / synth::kHouseSpeedMps * 30, 1.0);
  EXPECT_EQ(parse_synthetic_spec("synthetic:scene=house,speed=2").frames,
            SyntheticScene::house_loop_frames(2.0));
  EXPECT_EQ(parse_synthetic_spec("synthetic:scene=house,frames=7").frames, 7);
  EXPECT_EQ(parse_synthetic_spec("synthetic:scene=room").scene, synth::SceneLayout::kRoom);
  EXPECT_EQ(parse_synthetic_spec("synthetic:scene=room").frames, 300);
  try {
    parse_synthetic_spec("synthetic:scene=garden");
    ADD_FAILURE() << "scene=garden was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("room, house or twins"), std::string::npos) << e.what();
  }
  auto reader = make_synthetic_reader("synthetic:scene=house,frames=3,width=64,height=48");
  EXPECT_EQ(reader->description(), "synthetic house (3 frames, 64\u00d748, seed 1, noise on)");
  const auto settings = reader->recommended_settings();
  EXPECT_NE(std::find(settings.begin(), settings.end(),
                      std::pair<std::string, std::string>{"volume", "blocks"}),
            settings.end());
  EXPECT_TRUE(reader->has_colour());
}

TEST(SyntheticHouse, FloorPlanPathAndNoCubeHoldsIt) {
  const SyntheticScene scene = house();
  const Vec3d lo = scene.geometry().shell_lo(), hi = scene.geometry().shell_hi();
  const double plan_x = hi.x - lo.x, plan_z = hi.z - lo.z;
  EXPECT_GE(std::max(plan_x, plan_z), 15.0);
  EXPECT_GE(std::min(plan_x, plan_z), 10.0);
  EXPECT_GT(scene.geometry().primitive_count(), 100);

  // The path, frame by frame: at least 30 m, closed, and moving like the room's handheld
  // camera (at most 7.1 mm and about half a degree a frame).
  const int frames = scene.options().frames;
  double length_m = 0, max_step_m = 0, max_turn_deg = 0;
  double path_lo[3] = {1e9, 1e9, 1e9}, path_hi[3] = {-1e9, -1e9, -1e9};
  double Rp[3][3], tp[3];
  scene.pose(0, Rp, tp);
  for (int f = 1; f <= frames; ++f) {
    double R[3][3], t[3];
    scene.pose(f, R, t);
    const double step =
        std::sqrt((t[0] - tp[0]) * (t[0] - tp[0]) + (t[1] - tp[1]) * (t[1] - tp[1]) +
                  (t[2] - tp[2]) * (t[2] - tp[2]));
    double trace = 0;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) trace += R[i][j] * Rp[i][j];
    }
    const double turn_deg = std::acos(std::clamp((trace - 1) / 2, -1.0, 1.0)) * 180 / 3.14159265;
    if (f < frames) length_m += step;
    max_step_m = std::max(max_step_m, step);
    max_turn_deg = std::max(max_turn_deg, turn_deg);
    for (int a = 0; a < 3; ++a) {
      path_lo[a] = std::min(path_lo[a], t[a]);
      path_hi[a] = std::max(path_hi[a], t[a]);
    }
    std::copy(&R[0][0], &R[0][0] + 9, &Rp[0][0]);
    std::copy(t, t + 3, tp);
  }
  EXPECT_GE(length_m, 30.0);
  EXPECT_LE(max_step_m, 0.0071);
  EXPECT_LE(max_turn_deg, 0.55);
  // One loop brings the camera back where it started (frame `frames` is frame 0 again, up to
  // the last frame's fraction of a step).
  double R0[3][3], t0[3];
  scene.pose(0, R0, t0);
  EXPECT_LT(std::hypot(tp[0] - t0[0], tp[2] - t0[2]), 0.0071);
  // A dense 512³ cube at 1 cm spans 5.12 m: the camera alone travels farther than that along
  // both horizontal axes, and sees farther still.
  EXPECT_GT(path_hi[0] - path_lo[0], 5.12);
  EXPECT_GT(path_hi[2] - path_lo[2], 5.12);
}

TEST(SyntheticHouse, EveryViewSeesDepthInRangeAndNothingInsideTheNearClip) {
  // Every 10th frame at 80×60, exact depth: the camera stays clear of every surface, sees
  // enough within the sensor's range, and never stares at something nearer than the near clip.
  const SyntheticScene scene = house(",width=80,height=60,noise=0");
  const int w = 80, h = 60;
  const double f = 525.0 * w / 640.0, cx = (w - 1) / 2.0, cy = (h - 1) / 2.0;
  std::vector<double> depth(w * h);
  std::vector<float> cosines(w * h);
  double worst_in_range = 1, worst_too_near = 0, min_clearance_m = 1e9;
  for (int frame = 0; frame < scene.options().frames; frame += 10) {
    double R[3][3], t[3];
    scene.pose(frame, R, t);
    min_clearance_m =
        std::min(min_clearance_m, scene.geometry().signed_distance_m({t[0], t[1], t[2]}));
    scene.geometry().render(R, t, f, cx, cy, w, h, depth.data(), cosines.data());
    int in_range = 0, too_near = 0;
    for (double d : depth) {
      in_range += d >= KinectDepthModel::kMinDepthM && d <= KinectDepthModel::kMaxDepthM;
      too_near += d < KinectDepthModel::kMinDepthM;
    }
    worst_in_range = std::min(worst_in_range, static_cast<double>(in_range) / depth.size());
    worst_too_near = std::max(worst_too_near, static_cast<double>(too_near) / depth.size());
  }
  EXPECT_GE(min_clearance_m, 0.5);
  EXPECT_GE(worst_in_range, 0.25);
  EXPECT_LE(worst_too_near, 0.01);
}

TEST(SyntheticHouse, GroundTruthPosesAgreeWithRenderedDepth) {
  // Noise-free depth (whole millimetres) back-projected through the ground truth lands on the
  // true surface, within the rounding, at frames spread round the loop.
  const SyntheticScene scene = house(",width=64,height=48,noise=0");
  auto reader = make_synthetic_reader("synthetic:scene=house,width=64,height=48,noise=0");
  const auto gt = reader->ground_truth();
  ASSERT_EQ(static_cast<int>(gt.size()), scene.options().frames);
  const Intrinsics k = scene.intrinsics();
  HostImage<uint16_t> depth_mm;
  int checked = 0;
  double worst_m = 0;
  for (int frame = 0; frame < scene.options().frames; frame += 397) {
    scene.render(frame, depth_mm);
    // The pose from the reader's ground truth (quaternion), not the scene's own matrix.
    const auto& p = gt[frame];
    const double x = p.q[0], y = p.q[1], z = p.q[2], qw = p.q[3];
    const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * qw), 2 * (x * z + y * qw)},
                            {2 * (x * y + z * qw), 1 - 2 * (x * x + z * z), 2 * (y * z - x * qw)},
                            {2 * (x * z - y * qw), 2 * (y * z + x * qw), 1 - 2 * (x * x + y * y)}};
    for (int v = 0; v < depth_mm.height(); ++v) {
      for (int u = 0; u < depth_mm.width(); ++u) {
        const double d = depth_mm(u, v) / 1000.0;
        if (d <= 0 || d > 8.0) continue;
        const Vec3d q = back_project(R, p.t, k.fx, k.cx, k.cy, u, v, d);
        worst_m = std::max(worst_m, std::fabs(scene.geometry().signed_distance_m(q)));
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 10 * 64 * 48 / 2);
  // Half a millimetre of rounding along a ray, at most 16 px from the axis (the ray is within
  // 35° of the optical axis): under 0.7 mm off the surface.
  EXPECT_LE(worst_m, 0.0007);
}

TEST(SyntheticHouse, TrueSurfaceSamplesAndDistance) {
  const synth::RoomGeometry geometry(synth::SceneLayout::kHouse);
  // The first camera: 1.3 m above the floor, nothing nearer.
  EXPECT_NEAR(geometry.signed_distance_m({0, 0, 0}), 1.3, 1e-9);
  // Inside A's sideboard (plan x −0.5 … 1.5, z −2.0 … −1.55, 0.9 m high), 0.1 m below its
  // top; a metre above its top the nearest solid is the south wall, 0.2 m away.
  const double sx = 0.5 - synth::kHousePlanOriginX, sz = -1.8 - synth::kHousePlanOriginZ;
  EXPECT_NEAR(geometry.signed_distance_m({sx, synth::kFloorY - 0.8, sz}), -0.1, 1e-9);
  EXPECT_NEAR(geometry.signed_distance_m({sx, synth::kFloorY - 1.9, sz}), 0.2, 1e-9);

  const auto samples = geometry.sample_surface(0.05);
  double area = 0;
  int checked = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    area += samples[i].area_m2;
    if (i % 5 != 0) continue;
    const auto& s = samples[i];
    // On the surface, and facing free space: 10 µm along the normal is outside every solid (a
    // sample on a hidden face, where two primitives touch, would be inside one). NOTE: not a
    // millimetre: a ball resting on the floor has visible samples within 1 mm of it.
    ASSERT_NEAR(geometry.signed_distance_m(s.p), 0.0, 1e-6) << i;
    const Vec3d out{s.p.x + 1e-5 * s.n.x, s.p.y + 1e-5 * s.n.y, s.p.z + 1e-5 * s.n.z};
    ASSERT_GT(geometry.signed_distance_m(out), 0.0) << i;
    ++checked;
  }
  EXPECT_GT(checked, 10000);
  // The floor and ceiling alone are 2 × 184 m² less what stands on them; the walls add more.
  EXPECT_GT(area, 2 * 16.0 * 11.5 * 0.85);
  EXPECT_LT(area, 2000.0);
}

TEST(SyntheticHouse, BlockMapTracksAShortStretch) {
  // The house's own settings (volume=blocks, 1 cm voxels), 320×240 at compute size 2, 16
  // frames: every frame after SLAMBench's four start-up frames tracks, the trajectory follows
  // the ground truth, no block is refused, and the mesh lies on the true surface.
  const std::string spec = "synthetic:scene=house,frames=16,width=320,height=240";
  auto reader = make_synthetic_reader(spec);
  PipelineConfig config;
  for (const auto& [key, value] : reader->recommended_settings())
    set_config_value(config, key, value);
  ASSERT_EQ(config.volume.kind, MapKind::kBlocks);
  Pipeline pipeline(config, reader->default_intrinsics().value(), reader->width_px(),
                    reader->height_px(), BackendKind::kCpu);
  Frame frame;
  std::vector<Mat4f> poses;
  int tracked = 0, dropped = 0, blocks = 0;
  while (reader->next(frame).status == ReadStatus::kOk) {
    const FrameReport r = pipeline.process(frame.depth_mm);
    poses.push_back(r.T_world_cam);
    tracked += r.tracked;
    dropped += r.map_blocks_dropped;
    blocks = r.map_blocks;
  }
  ASSERT_EQ(poses.size(), 16u);
  EXPECT_EQ(tracked, 12);
  EXPECT_EQ(dropped, 0);
  EXPECT_GT(blocks, 1000);
  const auto gt = reader->ground_truth();
  Eigen::Matrix3Xd est_m(3, 16), gt_m(3, 16);
  for (int i = 0; i < 16; ++i) {
    for (int a = 0; a < 3; ++a) {
      est_m(a, i) = poses[i].m[a][3];
      gt_m(a, i) = gt[i].t[a];
    }
  }
  const double ate_m = eval::compute_ate(est_m, gt_m).stats_m.rmse;
  EXPECT_LT(ate_m, 0.01);
  // The camera moved (6.7 mm a frame), so a tracker that stood still would fail the ATE.
  EXPECT_GT(std::hypot(gt_m(0, 15) - gt_m(0, 0), gt_m(2, 15) - gt_m(2, 0)), 0.09);

  // Mesh vertices, through frame 0 into the scene frame: the median lies within a voxel of the
  // true surface.
  const MeshView mesh = pipeline.backend().extract_mesh();
  ASSERT_GT(mesh.vertex_count, 10000u);
  const SyntheticScene scene(parse_synthetic_spec(spec));
  double R0[3][3], t0[3];
  scene.pose(0, R0, t0);  // the map's frame is the first camera's (init_pose_factor 0,0,0)
  std::vector<double> distance_m;
  for (size_t i = 0; i < mesh.vertex_count; i += 7) {
    const Vec3f& p = mesh.vertices[i].p_m;
    const Vec3d q{R0[0][0] * p.x + R0[0][1] * p.y + R0[0][2] * p.z + t0[0],
                  R0[1][0] * p.x + R0[1][1] * p.y + R0[1][2] * p.z + t0[1],
                  R0[2][0] * p.x + R0[2][1] * p.y + R0[2][2] * p.z + t0[2]};
    distance_m.push_back(std::fabs(scene.geometry().signed_distance_m(q)));
  }
  std::nth_element(distance_m.begin(), distance_m.begin() + distance_m.size() / 2,
                   distance_m.end());
  EXPECT_LT(distance_m[distance_m.size() / 2], 0.01);
}

}  // namespace
}  // namespace kfx::io
