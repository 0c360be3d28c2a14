// Tests of the scene made to fool place recognition (synthetic:scene=twins,
// io/synthetic_twins.hpp): it renders along its whole path, its ground truth agrees with the
// depth it renders, the two rooms look the same from corresponding poses (and different from
// others), and kfx tracks a short stretch of it.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/platform.hpp"
#include "eval/ate.hpp"
#include "io/synthetic.hpp"
#include "io/synthetic_twins.hpp"
#include "pipeline/config.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx::io {
namespace {

using synth::RoomGeometry;
using synth::Vec3d;

SyntheticScene twins(const std::string& extra = "") {
  return SyntheticScene(parse_synthetic_spec("synthetic:scene=twins" + extra));
}

/// Frames from a frame in the first room's loop to the same place in the second's (speed 1).
constexpr int kPartnerFrames = static_cast<int>(synth::kTwinsSecondLoopStartS * 30);

Vec3d back_project(const double R[3][3], const double t[3], double f, double cx, double cy,
                   double x, double y, double z) {
  const double c[3] = {(x - cx) / f * z, (y - cy) / f * z, z};
  return {R[0][0] * c[0] + R[0][1] * c[1] + R[0][2] * c[2] + t[0],
          R[1][0] * c[0] + R[1][1] * c[1] + R[1][2] * c[2] + t[1],
          R[2][0] * c[0] + R[2][1] * c[1] + R[2][2] * c[2] + t[2]};
}

TEST(SyntheticTwins, SpecDefaultsDescriptionAndSettings) {
  const SyntheticOptions o = parse_synthetic_spec("synthetic:scene=twins");
  EXPECT_EQ(o.scene, synth::SceneLayout::kTwins);
  EXPECT_EQ(o.frames, 1200);  // 40 s at 30 Hz
  EXPECT_EQ(parse_synthetic_spec("synthetic:scene=twins,speed=2").frames, 600);
  EXPECT_EQ(parse_synthetic_spec("synthetic:scene=twins,frames=9").frames, 9);
  auto reader = make_synthetic_reader("synthetic:scene=twins,frames=3,width=64,height=48");
  EXPECT_EQ(reader->description(), "synthetic twin rooms (3 frames, 64\u00d748, seed 1, noise on)");
  const auto settings = reader->recommended_settings();
  EXPECT_NE(std::find(settings.begin(), settings.end(),
                      std::pair<std::string, std::string>{"volume", "blocks"}),
            settings.end());
  try {
    parse_synthetic_spec("synthetic:scene=triplets");
    ADD_FAILURE() << "scene=triplets was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("room, house or twins"), std::string::npos) << e.what();
  }
}

TEST(SyntheticTwins, PathVisitsBothRoomsSmoothly) {
  const SyntheticScene scene = twins();
  const Vec3d lo = scene.geometry().shell_lo(), hi = scene.geometry().shell_hi();
  EXPECT_NEAR(hi.x - lo.x, 2 * (synth::kRoomMaxX - synth::kRoomMinX) + synth::kTwinsWallM, 1e-12);
  // The first pose is the identity, the last the second room's start: 3.72 m along x.
  double R[3][3], t[3];
  scene.pose(0, R, t);
  EXPECT_NEAR(R[0][0] + R[1][1] + R[2][2], 3.0, 1e-12);
  EXPECT_NEAR(std::hypot(t[0], t[1], t[2]), 0.0, 1e-12);
  scene.pose(scene.options().frames, R, t);
  EXPECT_NEAR(t[0], synth::kTwinsOffsetM, 1e-9);
  // No jumps anywhere: at most 2 cm and 1° a frame (the walk's eased peak is 1.95 cm, the
  // turns' 0.94°), the handheld pace the tracker follows in the room.
  double Rp[3][3], tp[3];
  scene.pose(0, Rp, tp);
  double max_step_m = 0, max_turn_deg = 0, max_x = -1e9, min_clearance_m = 1e9;
  for (int f = 1; f <= scene.options().frames; ++f) {
    scene.pose(f, R, t);
    max_step_m = std::max(max_step_m, std::hypot(t[0] - tp[0], t[1] - tp[1], t[2] - tp[2]));
    double trace = 0;  // of Rpᵀ·R
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) trace += Rp[j][i] * R[j][i];
    max_turn_deg = std::max(max_turn_deg,
                            std::acos(std::clamp((trace - 1) / 2, -1.0, 1.0)) * 180 / 3.14159265);
    max_x = std::max(max_x, t[0]);
    // Always in free space, clear of every wall and the doorway's jambs: the path really
    // passes through the doorway (the back wall is 0.35 m behind the first camera).
    min_clearance_m =
        std::min(min_clearance_m, scene.geometry().signed_distance_m({t[0], t[1], t[2]}));
    std::copy(&R[0][0], &R[0][0] + 9, &Rp[0][0]);
    std::copy(t, t + 3, tp);
  }
  EXPECT_LT(max_step_m, 0.02);
  EXPECT_LT(max_turn_deg, 1.0);
  EXPECT_GT(max_x, synth::kTwinsOffsetM);  // it walked the second room's loop
  EXPECT_GT(min_clearance_m, 0.3);
}

TEST(SyntheticTwins, TrueSurfaceIsTheRoomsTwiceAndTheWallBetween) {
  // The evaluation's true surface: twice the room's, plus the wall between them, less the
  // doorway and the stretches of the two side walls that the wall between now covers.
  const RoomGeometry room;
  const RoomGeometry pair(synth::SceneLayout::kTwins);
  EXPECT_EQ(pair.primitive_count(), 2 * room.primitive_count() + 2);
  double room_m2 = 0, pair_m2 = 0;
  for (const synth::SurfaceSample& s : room.sample_surface(0.05)) room_m2 += s.area_m2;
  for (const synth::SurfaceSample& s : pair.sample_surface(0.05)) pair_m2 += s.area_m2;
  EXPECT_GT(pair_m2, 1.9 * room_m2);
  EXPECT_LT(pair_m2, 2.1 * room_m2);
  // The doorway is open, the wall beside it solid, the two rooms' corresponding points alike.
  const double wall_x = synth::kRoomMaxX + 0.5 * synth::kTwinsWallM;
  EXPECT_GT(pair.signed_distance_m({wall_x, 0.0, 0.3}), 0.0);
  EXPECT_LT(pair.signed_distance_m({wall_x, 0.0, 2.0}), 0.0);
  for (const Vec3d p : {Vec3d{0.1, 0.2, 2.0}, Vec3d{-1.0, 1.0, 3.0}, Vec3d{0.5, -1.2, 1.2}}) {
    EXPECT_NEAR(pair.signed_distance_m(p),
                pair.signed_distance_m({p.x + synth::kTwinsOffsetM, p.y, p.z}), 1e-9);
  }
}

TEST(SyntheticTwins, GroundTruthPosesAgreeWithRenderedDepth) {
  // Noise-free depth back-projected through the reader's ground truth lands on the true
  // surface within the millimetre rounding, in both rooms and on the way between them.
  auto reader = make_synthetic_reader("synthetic:scene=twins,width=64,height=48,noise=0");
  const SyntheticScene scene = twins(",width=64,height=48,noise=0");
  const auto gt = reader->ground_truth();
  ASSERT_EQ(static_cast<int>(gt.size()), 1200);
  const Intrinsics k = scene.intrinsics();
  HostImage<uint16_t> depth_mm;
  int checked = 0;
  double worst_m = 0;
  for (int frame : {0, 170, 380, 520, 650, 800, 1000, 1199}) {
    scene.render(frame, depth_mm);
    const auto& p = gt[frame];
    const double x = p.q[0], y = p.q[1], z = p.q[2], qw = p.q[3];
    const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * qw), 2 * (x * z + y * qw)},
                            {2 * (x * y + z * qw), 1 - 2 * (x * x + z * z), 2 * (y * z - x * qw)},
                            {2 * (x * z - y * qw), 2 * (y * z + x * qw), 1 - 2 * (x * x + y * y)}};
    int valid = 0;
    for (int v = 0; v < depth_mm.height(); ++v) {
      for (int u = 0; u < depth_mm.width(); ++u) {
        const double d = depth_mm(u, v) / 1000.0;
        if (d <= 0) continue;
        const Vec3d q = back_project(R, p.t, k.fx, k.cx, k.cy, u, v, d);
        worst_m = std::max(worst_m, std::fabs(scene.geometry().signed_distance_m(q)));
        ++valid;
      }
    }
    EXPECT_EQ(valid, 64 * 48) << "frame " << frame;  // a closed scene: every ray hits
    checked += valid;
  }
  EXPECT_EQ(checked, 8 * 64 * 48);
  // Half a millimetre of rounding along a ray within 35° of the axis: under 0.7 mm.
  EXPECT_LE(worst_m, 0.0007);
}

/// Pixels whose noise-free depth differs by more than 1 mm between two frames, and pixels
/// whose colour differs.
struct ImageDifference {
  int depth_px = 0;
  int colour_px = 0;
};

ImageDifference compare_frames(const SyntheticScene& scene, int a, int b) {
  HostImage<uint16_t> da, db;
  HostImage<Rgb8> ca, cb;
  scene.render(a, da, &ca);
  scene.render(b, db, &cb);
  ImageDifference d;
  for (int v = 0; v < da.height(); ++v) {
    for (int u = 0; u < da.width(); ++u) {
      d.depth_px += std::abs(int(da(u, v)) - int(db(u, v))) > 1;
      const Rgb8 x = ca(u, v), y = cb(u, v);
      d.colour_px += std::abs(x.r - y.r) > 1 || std::abs(x.g - y.g) > 1 || std::abs(x.b - y.b) > 1;
    }
  }
  return d;
}

TEST(SyntheticTwins, TheRoomsLookTheSameFromCorrespondingPoses) {
  const SyntheticScene scene = twins(",width=160,height=120,noise=0");
  for (int f : {0, 60, 137, 225, 295}) {
    // The partner pose is the same pose shifted 3.72 m along x.
    double Ra[3][3], ta[3], Rb[3][3], tb[3];
    scene.pose(f, Ra, ta);
    scene.pose(f + kPartnerFrames, Rb, tb);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(Ra[i][j], Rb[i][j], 1e-12);
    EXPECT_NEAR(tb[0] - ta[0], synth::kTwinsOffsetM, 1e-9);
    EXPECT_NEAR(tb[1], ta[1], 1e-12);
    EXPECT_NEAR(tb[2], ta[2], 1e-12);
    // Depth and colour agree, but for the odd pixel where the shift's rounding moves a ray
    // across a millimetre boundary or an edge.
    const ImageDifference same = compare_frames(scene, f, f + kPartnerFrames);
    EXPECT_LE(same.depth_px, 160 * 120 / 1000) << "frame " << f;
    EXPECT_LE(same.colour_px, 160 * 120 / 1000) << "frame " << f;
    // Control: four frames (about 2.7 cm and 1°) later in the other room already differs.
    const ImageDifference other = compare_frames(scene, f, f + kPartnerFrames + 4);
    EXPECT_GT(other.depth_px, 160 * 120 / 4) << "frame " << f;
  }
}

TEST(SyntheticTwins, NoViewOfTheLoopSeesTheDoorway) {
  // Every frame of the first room's loop against its partner, at a small size: the doorway (or
  // anything else that tells the rooms apart) would show as a patch of differing depth.
  const SyntheticScene scene = twins(",width=64,height=48,noise=0");
  int worst_px = 0, worst_frame = -1;
  for (int f = 0; f < kPartnerFrames / 3; ++f) {
    const int differing = compare_frames(scene, f, f + kPartnerFrames).depth_px;
    if (differing > worst_px) {
      worst_px = differing;
      worst_frame = f;
    }
  }
  EXPECT_LE(worst_px, 2) << "frame " << worst_frame;
}

TEST(SyntheticTwins, BlockMapTracksAShortStretch) {
  // The scene's own settings (blocks, 1 cm), 320×240 at compute size 2 as the house's test,
  // 12 frames in the first room: every frame after the four start-up frames tracks, and the
  // trajectory follows the ground truth.
  const std::string spec = "synthetic:scene=twins,frames=12,width=320,height=240";
  auto reader = make_synthetic_reader(spec);
  PipelineConfig config;
  for (const auto& [key, value] : reader->recommended_settings())
    set_config_value(config, key, value);
  ASSERT_EQ(config.volume.kind, MapKind::kBlocks);
  Pipeline pipeline(config, reader->default_intrinsics().value(), reader->width_px(),
                    reader->height_px(), BackendKind::kCpu);
  Frame frame;
  std::vector<Mat4f> poses;
  int tracked = 0, dropped = 0;
  while (reader->next(frame).status == ReadStatus::kOk) {
    const FrameReport r = pipeline.process(frame.depth_mm);
    poses.push_back(r.T_world_cam);
    tracked += r.tracked;
    dropped += r.map_blocks_dropped;
  }
  ASSERT_EQ(poses.size(), 12u);
  EXPECT_EQ(tracked, 8);
  EXPECT_EQ(dropped, 0);
  const auto gt = reader->ground_truth();
  Eigen::Matrix3Xd est_m(3, 12), gt_m(3, 12);
  for (int i = 0; i < 12; ++i) {
    for (int a = 0; a < 3; ++a) {
      est_m(a, i) = poses[i].m[a][3];
      gt_m(a, i) = gt[i].t[a];
    }
  }
  EXPECT_LT(eval::compute_ate(est_m, gt_m).stats_m.rmse, 0.01);
  // The camera moved, so a tracker that stood still would fail the ATE.
  EXPECT_GT(std::hypot(gt_m(0, 11) - gt_m(0, 0), gt_m(2, 11) - gt_m(2, 0)), 0.06);
}

}  // namespace
}  // namespace kfx::io
