/// Work in another map between frames (Pipeline::clear_map, integrate_into_map, track_in_map,
/// resume_in_map; loop closure's verification and rebuild): it finds the pose a frame was taken
/// at in a map fused from another frame, and after resume_in_map() the run goes on exactly as
/// if nothing had happened in between (same poses, bit for bit), on every backend and map kind.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "api/internal.hpp"
#include "io/reader.hpp"
#include "kfx/kfx.hpp"
#include "support/backend_map_params.hpp"

namespace kfx {
namespace {

const char* kInput = "synthetic:frames=16,width=160,height=120";
constexpr int kSideAfter = 12;  ///< frames run before the side work

float distance_m(const Mat4f& a, const Mat4f& b) {
  const Vec3f d = a.translation_part() - b.translation_part();
  return std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
}

class SideMaps : public test::BackendMapTest {};

TEST_P(SideMaps, VerifyInAnotherMapThenResumeAsIfNothingHappened) {
  const Settings settings = this->settings(96);
  Sequence sequence(kInput);
  std::vector<io::Frame> frames;
  {
    auto reader = io::open_reader(kInput);
    io::Frame frame;
    while (reader->next(frame).status == io::ReadStatus::kOk) frames.push_back(frame);
  }
  Reconstruction plain(settings, sequence), side(settings, sequence);
  std::vector<Mat4f> plain_poses, side_poses;
  for (size_t i = 0; i < frames.size(); ++i) {
    ReconstructionAccess::submit(plain, frames[i]);
    plain.collect();
    plain_poses.push_back(ReconstructionAccess::last_report(plain).T_world_cam);
    ReconstructionAccess::submit(side, frames[i]);
    side.collect();
    side_poses.push_back(ReconstructionAccess::last_report(side).T_world_cam);
    if (static_cast<int>(i) != kSideAfter) continue;
    Pipeline& p = ReconstructionAccess::pipeline(side);
    const int map = p.backend().create_map();
    p.clear_map(map);
    // Frame 8 fused alone into the other map, frame 12 tracked against it from frame 8's pose.
    p.integrate_into_map(map, side_poses[8], frames[8].depth_mm.view(), frames[8].rgb.view());
    const FrameReport found = p.track_in_map(map, side_poses[8], frames[12].depth_mm.view());
    EXPECT_TRUE(found.tracked);
    EXPECT_LT(distance_m(found.T_world_cam, side_poses[12]), 0.01f)
        << "moved from " << distance_m(side_poses[8], side_poses[12]) << " m away";
    p.resume_in_map(0, side_poses.back());
  }
  ASSERT_EQ(side_poses.size(), plain_poses.size());
  for (size_t i = 0; i < plain_poses.size(); ++i) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) {
        EXPECT_EQ(side_poses[i].m[r][c], plain_poses[i].m[r][c]) << "frame " << i;
      }
    }
  }
}

KFX_INSTANTIATE_BACKEND_MAP_TESTS(SideMaps);

}  // namespace
}  // namespace kfx
