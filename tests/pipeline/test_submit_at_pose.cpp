/// Frames at given poses (Pipeline::submit_at_pose): the pose travels with the frame, so frames
/// may be in flight and the map is the same as when each frame is collected before the next is
/// placed; a frame whose view nothing needs raycasts nothing, and a tracked frame after it
/// waits for a fresh reference view instead of tracking against another pose's.

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "backend/backend.hpp"
#include "io/reader.hpp"
#include "pipeline/config.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx {
namespace {

constexpr const char* kInput = "synthetic:frames=10,width=160,height=120";

struct Frames {
  std::vector<io::Frame> frames;
  std::vector<Mat4f> poses;  ///< tracked by a normal run
  PipelineConfig config;
  Intrinsics k;
  int width = 0, height = 0;
};

Frames tracked_frames() {
  Frames out;
  auto reader = io::open_reader(kInput);
  for (const auto& [key, value] : reader->recommended_settings()) {
    set_config_value(out.config, key, value);
  }
  set_config_value(out.config, "volume_resolution", "64");
  out.k = reader->default_intrinsics().value();
  out.width = reader->width_px();
  out.height = reader->height_px();
  Pipeline pipeline(out.config, out.k, out.width, out.height, BackendKind::kCpu);
  io::Frame frame;
  while (reader->next(frame).status == io::ReadStatus::kOk) {
    out.frames.push_back(frame);
    out.poses.push_back(pipeline.process(frame.depth_mm).T_world_cam);
  }
  return out;
}

Mesh mesh_of(Pipeline& pipeline) { return Mesh(pipeline.extract_mesh()); }

/// On `kind`: one frame collected before the next is placed, then two in flight.
void fuse_in_flight_and_one_by_one(BackendKind kind) {
  const Frames in = tracked_frames();
  ASSERT_EQ(in.frames.size(), 10u);
  Pipeline one_by_one(in.config, in.k, in.width, in.height, kind);
  for (size_t i = 0; i < in.frames.size(); ++i) {
    one_by_one.submit_at_pose(in.poses[i], in.frames[i].depth_mm.view());
    const FrameReport r = one_by_one.collect();
    EXPECT_TRUE(r.integrated) << "frame " << i;
    EXPECT_EQ(std::memcmp(&r.T_world_cam, &in.poses[i], sizeof(Mat4f)), 0) << "frame " << i;
  }
  // Two frames in flight at a time, no view raycast.
  Pipeline in_flight(in.config, in.k, in.width, in.height, kind);
  for (size_t i = 0; i < in.frames.size(); ++i) {
    in_flight.submit_at_pose(in.poses[i], in.frames[i].depth_mm.view(), {}, false);
    if (in_flight.frames_in_flight() == 2) {
      const FrameReport r = in_flight.collect();
      EXPECT_TRUE(r.integrated) << "frame " << r.index;
      EXPECT_FALSE(r.raycast) << "frame " << r.index;
      EXPECT_FALSE(r.tracking_ran) << "frame " << r.index;
      EXPECT_EQ(std::memcmp(&r.T_world_cam, &in.poses[r.index], sizeof(Mat4f)), 0)
          << "frame " << r.index;
    }
  }
  while (in_flight.frames_in_flight() > 0) in_flight.collect();
  const Mesh a = mesh_of(one_by_one), b = mesh_of(in_flight);
  ASSERT_GT(a.vertices.size(), 1000u);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  EXPECT_EQ(
      std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(MeshVertex)), 0);
}

TEST(SubmitAtPose, FramesInFlightFuseTheSameMapAsFramesCollectedOneByOne) {
  fuse_in_flight_and_one_by_one(BackendKind::kCpu);
}

// On the GPU the staged pose is copied in stream order and the frame adopts it inside its
// recorded graph (shape bit 64), replayed for every later frame at a given pose.
TEST(SubmitAtPose, FramesInFlightFuseTheSameMapAsFramesCollectedOneByOneOnTheGpu) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  fuse_in_flight_and_one_by_one(BackendKind::kCuda);
}

TEST(SubmitAtPose, TrackedFrameAfterAFrameWithoutViewWaitsForAFreshOne) {
  const Frames in = tracked_frames();
  Pipeline pipeline(in.config, in.k, in.width, in.height, BackendKind::kCpu);
  for (int i = 0; i < 6; ++i) {
    pipeline.submit_at_pose(in.poses[i], in.frames[i].depth_mm.view(), {}, false);
    EXPECT_FALSE(pipeline.collect().raycast) << "frame " << i;
  }
  // No reference view at this pose yet: not tracked, but raycast (and so the next one tracks).
  const FrameReport first = pipeline.process(in.frames[6].depth_mm);
  EXPECT_FALSE(first.tracking_ran);
  EXPECT_TRUE(first.raycast);
  const FrameReport second = pipeline.process(in.frames[7].depth_mm);
  EXPECT_TRUE(second.tracking_ran);
  EXPECT_TRUE(second.tracked);
}

}  // namespace
}  // namespace kfx
