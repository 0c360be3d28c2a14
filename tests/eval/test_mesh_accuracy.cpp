/// Accuracy of kfx's mesh against the truth: on the synthetic room, the distance of mesh
/// vertices to the scene's analytic surfaces; on TUM fr1/xyz, agreement with the depth images
/// back-projected through kfx's own poses.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "io/reader.hpp"
#include "io/synthetic_scene.hpp"
#include "pipeline/pipeline.hpp"
#include "support/mesh_test_support.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

/// A rigid transform in double precision: p' = R p + t.
struct Rigid {
  double R[3][3];
  double t[3];
  static Rigid from(const io::StampedPose& s) {
    const double x = s.q[0], y = s.q[1], z = s.q[2], w = s.q[3];
    Rigid r{{{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
             {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
             {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}},
            {s.t[0], s.t[1], s.t[2]}};
    return r;
  }
  static Rigid from(const Mat4f& m) {
    Rigid r{};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) r.R[i][j] = m.m[i][j];
      r.t[i] = m.m[i][3];
    }
    return r;
  }
  Rigid inverse() const {
    Rigid r{};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) r.R[i][j] = R[j][i];
    }
    for (int i = 0; i < 3; ++i) r.t[i] = -(r.R[i][0] * t[0] + r.R[i][1] * t[1] + r.R[i][2] * t[2]);
    return r;
  }
  Rigid operator*(const Rigid& b) const {
    Rigid r{};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j)
        r.R[i][j] = R[i][0] * b.R[0][j] + R[i][1] * b.R[1][j] + R[i][2] * b.R[2][j];
      r.t[i] = R[i][0] * b.t[0] + R[i][1] * b.t[1] + R[i][2] * b.t[2] + t[i];
    }
    return r;
  }
  io::synth::Vec3d apply(double x, double y, double z) const {
    return {R[0][0] * x + R[0][1] * y + R[0][2] * z + t[0],
            R[1][0] * x + R[1][1] * y + R[1][2] * z + t[1],
            R[2][0] * x + R[2][1] * y + R[2][2] * z + t[2]};
  }
};

/// A finished run: its mesh, its poses (volume frame) and the reader's ground truth.
struct MeshedRun {
  Mesh mesh;
  std::vector<Mat4f> poses;
  std::vector<io::Frame> frames;  ///< kept only when asked
  std::vector<io::StampedPose> ground_truth;
  Intrinsics input_k;
  float voxel_m = 0;
  float volume_size_m = 0;
};

MeshedRun run_and_mesh(const std::string& input, PipelineConfig config, int max_frames,
                       bool keep_frames) {
  auto reader = io::open_reader(input);
  for (const auto& [key, value] : reader->recommended_settings())
    set_config_value(config, key, value);
  MeshedRun run;
  run.input_k = reader->default_intrinsics().value();
  run.ground_truth = reader->ground_truth();
  Pipeline pipeline(config, run.input_k, reader->width_px(), reader->height_px(),
                    BackendKind::kCpu);
  io::Frame frame;
  while (static_cast<int>(run.poses.size()) < max_frames &&
         reader->next(frame).status == io::ReadStatus::kOk) {
    run.poses.push_back(pipeline.process(frame.depth_mm).T_world_cam);
    if (keep_frames) run.frames.push_back(frame);
  }
  run.mesh = Mesh(pipeline.backend().extract_mesh());
  run.volume_size_m = pipeline.config().volume.size_m;
  run.voxel_m = run.volume_size_m / pipeline.config().volume.resolution_vox;
  return run;
}

/// Distance (metres) of mesh vertices to the synthetic room's true surfaces. Vertices go
/// from the volume frame to the scene frame through frame 0 (untracked: the initial pose and
/// the true first pose), so tracking drift counts against the mesh. The room answers ray casts
/// only, so a vertex's distance is measured along rays: from a point 5 cm out along the
/// vertex's normal back towards the vertex, and from true camera positions through it; each
/// gives the gap between vertex and true hit along the ray times |cos| of the incidence, the
/// distance to the true surface's tangent plane. The smallest counts (a ray can meet another,
/// nearer surface first: an occluder, or an edge when the normal is off).
/// The mean over every third vertex, and (for the report) over those whose normal faces at
/// least one camera: back-facing ones are TSDF fusion's own artefacts (the far side of a thin
/// board, where the truncation band behind its front meets free space seen past it).
struct RoomDistance {
  double mean_m = 0;         ///< over vertices facing a camera
  double mean_all_m = 0;     ///< over every sampled vertex
  double seen_fraction = 0;  ///< facing / sampled
};
RoomDistance distance_to_room(const MeshedRun& run) {
  const io::synth::RoomGeometry room;
  const Rigid scene_from_volume =
      Rigid::from(run.ground_truth.front()) * Rigid::from(run.poses.front()).inverse();
  std::vector<io::synth::Vec3d> cameras;
  for (size_t f = 0; f < run.poses.size(); f += 2) {
    const auto& t = run.ground_truth[f].t;
    cameras.push_back({t[0], t[1], t[2]});
  }
  constexpr double kOffset_m = 0.05;
  double sum = 0, sum_all = 0;
  int count = 0, count_all = 0;
  for (size_t i = 0; i < run.mesh.vertices.size(); i += 3) {
    const MeshVertex& v = run.mesh.vertices[i];
    const io::synth::Vec3d q = scene_from_volume.apply(v.p_m.x, v.p_m.y, v.p_m.z);
    const io::synth::Vec3d q0 = scene_from_volume.apply(0, 0, 0);
    const io::synth::Vec3d n1 = scene_from_volume.apply(v.normal.x, v.normal.y, v.normal.z);
    const io::synth::Vec3d n{n1.x - q0.x, n1.y - q0.y, n1.z - q0.z};
    const io::synth::Vec3d out{q.x + kOffset_m * n.x, q.y + kOffset_m * n.y, q.z + kOffset_m * n.z};
    const io::synth::RayHit back = room.cast(out, {-n.x, -n.y, -n.z});
    double best = std::fabs(back.t - kOffset_m) * back.cos_incidence;
    bool seen = false;
    for (const auto& o : cameras) {
      seen = seen || (o.x - q.x) * n.x + (o.y - q.y) * n.y + (o.z - q.z) * n.z > 0;
      const io::synth::Vec3d d{q.x - o.x, q.y - o.y, q.z - o.z};
      const double length = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
      const io::synth::RayHit hit = room.cast(o, d);
      best = std::min(best, std::fabs(hit.t - 1.0) * length * hit.cos_incidence);
    }
    sum_all += best;
    ++count_all;
    if (!seen) continue;
    sum += best;
    ++count;
  }
  RoomDistance d;
  d.mean_m = count > 0 ? sum / count : 1e9;
  d.mean_all_m = count_all > 0 ? sum_all / count_all : 1e9;
  d.seen_fraction = count_all > 0 ? static_cast<double>(count) / count_all : 0;
  return d;
}

void print_room_distance(const char* what, const RoomDistance& d, float voxel_m) {
  std::printf(
      "synthetic room, %s: mean vertex distance to the true surface %.2f mm = %.3f voxel "
      "over all vertices; %.2f mm = %.3f voxel over the %.1f %% facing a camera\n",
      what, d.mean_all_m * 1000, d.mean_all_m / voxel_m, d.mean_m * 1000, d.mean_m / voxel_m,
      d.seen_fraction * 100);
}

PipelineConfig every_frame_integrated() {
  PipelineConfig config;
  set_config_value(config, "integration_rate", "1");
  set_config_value(config, "compute_size_ratio", "1");
  return config;
}

// 24 frames of 320×240 at compute size 1, the room's recommended 4.2 m volume at 256³
// (16.4 mm voxels), the camera at a tenth of its usual speed. NOTE: SLAMBench (and so kfx's
// exact preset) integrates frames 0–3 at the initial pose before tracking starts; at full speed
// the camera has turned by 1.2° by frame 3, which smears the model by up to 6 cm at 3 m
// (measured: 0.56 voxel mean over 8 frames, 0.16 with the camera still). That is the
// pipeline's start-up, not the mesher; at a tenth of the speed it stays below 0.1°.
const char* const kSyntheticNoiseOff = "synthetic:frames=24,width=320,height=240,noise=0,speed=0.1";
const char* const kSyntheticNoiseOn = "synthetic:frames=24,width=320,height=240,noise=1,speed=0.1";

TEST(MeshAccuracy, SyntheticRoomWithoutNoiseWithinQuarterVoxel) {
  const MeshedRun run = run_and_mesh(kSyntheticNoiseOff, every_frame_integrated(), 24, false);
  ASSERT_GT(run.mesh.triangles.size(), 10000u);
  const RoomDistance d = distance_to_room(run);
  print_room_distance("noise off", d, run.voxel_m);
  EXPECT_LE(d.mean_all_m, 0.25 * run.voxel_m);
}

TEST(MeshAccuracy, SyntheticRoomWithNoiseReported) {
  const MeshedRun run = run_and_mesh(kSyntheticNoiseOn, every_frame_integrated(), 24, false);
  ASSERT_GT(run.mesh.triangles.size(), 10000u);
  const RoomDistance d = distance_to_room(run);
  print_room_distance("Kinect-like noise", d, run.voxel_m);
  // A report, with a loose sanity bound: noise must not move the surface by a voxel on average.
  EXPECT_LE(d.mean_all_m, run.voxel_m);
}

// Fusion at given poses (Pipeline::submit_at_pose): the room at full speed, every frame fused at
// its true pose, carried into the volume frame through the first pose. Tracking is off, so the
// bootstrap frames' smear (above) is gone too: the mesh lies within a quarter voxel of the true
// surface, as the slow camera's tracked run does.
TEST(MeshAccuracy, SyntheticRoomFusedAtTruePosesWithinQuarterVoxel) {
  const char* const input = "synthetic:frames=24,width=320,height=240,noise=0";
  auto reader = io::open_reader(input);
  PipelineConfig config = every_frame_integrated();
  for (const auto& [key, value] : reader->recommended_settings())
    set_config_value(config, key, value);
  MeshedRun run;
  run.input_k = reader->default_intrinsics().value();
  run.ground_truth = reader->ground_truth();
  Pipeline pipeline(config, run.input_k, reader->width_px(), reader->height_px(),
                    BackendKind::kCpu);
  const Rigid volume_from_scene =
      Rigid::from(pipeline.initial_pose()) * Rigid::from(run.ground_truth.front()).inverse();
  io::Frame frame;
  for (int f = 0; f < 24 && reader->next(frame).status == io::ReadStatus::kOk; ++f) {
    const Rigid pose = volume_from_scene * Rigid::from(run.ground_truth[f]);
    Mat4f T = Mat4f::identity();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) T.m[i][j] = static_cast<float>(pose.R[i][j]);
      T.m[i][3] = static_cast<float>(pose.t[i]);
    }
    pipeline.submit_at_pose(T, frame.depth_mm.view());
    const FrameReport report = pipeline.collect();
    ASSERT_TRUE(report.integrated) << "frame " << f;
    ASSERT_FALSE(report.tracking_ran) << "frame " << f;
    run.poses.push_back(report.T_world_cam);
  }
  run.mesh = Mesh(pipeline.backend().extract_mesh());
  run.voxel_m = pipeline.config().volume.size_m / pipeline.config().volume.resolution_vox;
  ASSERT_GT(run.mesh.triangles.size(), 10000u);
  const RoomDistance d = distance_to_room(run);
  print_room_distance("fused at the true poses, full speed", d, run.voxel_m);
  EXPECT_LE(d.mean_all_m, 0.25 * run.voxel_m);
}

TEST(MeshAccuracy, TumFr1XyzAgreesWithBackProjectedDepth) {
  const std::string sequence = "data/tum_fr1_xyz";
  if (!test::shared_exists(sequence)) GTEST_SKIP() << test::shared_path(sequence) << " is missing";
  // The first 60 frames (2 s of the sequence) keep the test fast; default settings.
  constexpr int kFrames = 60;
  const MeshedRun run = run_and_mesh(test::shared_path(sequence), PipelineConfig{}, kFrames, true);
  ASSERT_GT(run.mesh.triangles.size(), 10000u);
  // Depth points of every 6th frame, every 2nd pixel, into the volume frame by kfx's poses.
  std::vector<Vec3f> depth_points;
  const Intrinsics& k = run.input_k;
  for (size_t f = 0; f < run.frames.size(); f += 6) {
    const HostImage<uint16_t>& depth = run.frames[f].depth_mm;
    const Rigid T = Rigid::from(run.poses[f]);
    for (int y = 0; y < depth.height(); y += 2) {
      for (int x = 0; x < depth.width(); x += 2) {
        const double d = depth(x, y) / 1000.0;
        if (d <= 0) continue;
        const auto p = T.apply((x - k.cx) / k.fx * d, (y - k.cy) / k.fy * d, d);
        depth_points.push_back(Vec3f{float(p.x), float(p.y), float(p.z)});
      }
    }
  }
  ASSERT_GT(depth_points.size(), 100000u);
  // Vertex → nearest depth point.
  const test::PointGrid depth_grid(depth_points, 0.03);
  std::vector<double> vertex_to_depth;
  for (const auto& v : run.mesh.vertices) vertex_to_depth.push_back(depth_grid.nearest_m(v.p_m));
  std::nth_element(vertex_to_depth.begin(), vertex_to_depth.begin() + vertex_to_depth.size() / 2,
                   vertex_to_depth.end());
  const double median_m = vertex_to_depth[vertex_to_depth.size() / 2];
  // Depth point inside the volume → nearest mesh vertex (an upper bound on the distance to the
  // mesh surface).
  const test::PointGrid mesh_grid(test::positions(run.mesh), 0.03);
  int inside = 0, near = 0;
  for (const auto& p : depth_points) {
    if (p.x < 0 || p.y < 0 || p.z < 0 || p.x > run.volume_size_m || p.y > run.volume_size_m ||
        p.z > run.volume_size_m) {
      continue;
    }
    ++inside;
    if (mesh_grid.nearest_m(p) <= 0.03) ++near;
  }
  const double near_fraction = static_cast<double>(near) / inside;
  std::printf(
      "tum_fr1_xyz, %d frames: median vertex-to-depth %.2f mm, %.1f %% of %d depth points "
      "inside the volume within 3 cm of the mesh\n",
      kFrames, median_m * 1000, near_fraction * 100, inside);
  EXPECT_LE(median_m, 0.01);
  EXPECT_GE(near_fraction, 0.80);
}

}  // namespace
}  // namespace kfx
