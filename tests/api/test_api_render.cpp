/// Reconstruction::render and render_depth from any pose, on both map kinds (volume=dense and
/// volume=blocks) and both backends: the pictures hold the surface the camera saw.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "kfx/kfx.hpp"
#include "support/backend_map_params.hpp"

namespace kfx {
namespace {

const char* kInput = "synthetic:frames=8,width=160,height=120,noise=0";

class ApiRender : public test::BackendMapTest {
 protected:
  Settings settings() const { return BackendMapTest::settings(128); }
};

/// Fraction of the pixels where both images have depth whose depths differ by less than
/// `tolerance_m`, and how many such pixels there are.
struct Agreement {
  size_t both = 0;
  double close_share = 0.0;
};
Agreement agreement(const std::vector<float>& a, const std::vector<float>& b, float tolerance_m) {
  Agreement out;
  size_t close = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (!(a[i] > 0.0f && b[i] > 0.0f)) continue;
    ++out.both;
    close += std::fabs(a[i] - b[i]) < tolerance_m;
  }
  out.close_share = out.both ? double(close) / out.both : 0.0;
  return out;
}

/// Frame `frame`'s depth (metres) at compute size: input pixel (x·ratio, y·ratio), as the
/// pipeline's mm → m step reads it.
std::vector<float> seen_depth_m(const SequenceFrame& frame, int width_px, int height_px) {
  const int ratio = frame.width_px / width_px;
  std::vector<float> out(static_cast<size_t>(width_px) * height_px);
  for (int y = 0; y < height_px; ++y) {
    for (int x = 0; x < width_px; ++x) {
      out[static_cast<size_t>(y) * width_px + x] =
          frame.depth_mm[static_cast<size_t>(y * ratio) * frame.width_px + x * ratio] / 1000.0f;
    }
  }
  return out;
}

TEST_P(ApiRender, DepthFromAnEarlierPoseIsWhatTheCameraSawThere) {
  Sequence sequence(kInput);
  std::vector<SequenceFrame> frames;
  SequenceFrame frame;
  while (sequence.next(frame) == ReadStatus::kOk) frames.push_back(frame);
  ASSERT_EQ(frames.size(), 8u);
  Reconstruction r(settings(), sequence);
  for (const auto& f : frames) r.process(f);
  // Not the current pose: frame 5's (tracked; frames 0-3 are the untracked bootstrap).
  const int earlier = 5;
  ASSERT_TRUE(r.trajectory()[earlier].tracked);
  const FloatImage depth = r.render_depth(r.trajectory()[earlier].T_world_cam);
  ASSERT_EQ(depth.width_px, r.compute_width_px());
  ASSERT_EQ(depth.height_px, r.compute_height_px());
  const std::vector<float> seen = seen_depth_m(frames[earlier], depth.width_px, depth.height_px);
  size_t rendered = 0, observed = 0;
  for (size_t i = 0; i < seen.size(); ++i) {
    rendered += depth.values[i] > 0.0f;
    observed += seen[i] > 0.0f;
  }
  // The model covers what the camera saw there (the room fills the view).
  EXPECT_GT(rendered, observed * 9 / 10);
  // 3 cm, about one voxel (128³ over the synthetic room's 4.2 m); the pose is tracked, not the
  // ground truth, and pixels on depth edges may hit the other side of the edge. Measured on the
  // CPU: 94 % of the pixels within 3 cm from frame 5's pose; from frame 7's or frame 2's pose
  // (the camera a few centimetres away) 82 % and 79 %, so the bound tells the pose apart.
  const Agreement a = agreement(depth.values, seen, 0.03f);
  EXPECT_GT(a.both, seen.size() * 8 / 10);
  EXPECT_GT(a.close_share, 0.9) << "of " << a.both << " pixels";
}

TEST_P(ApiRender, ShadedViewLightsTheSurfaceAndLooksAwayToNothing) {
  Sequence sequence(kInput);
  Reconstruction r(settings(), sequence);
  SequenceFrame frame;
  while (sequence.next(frame) == ReadStatus::kOk) r.process(frame);
  const RgbaImage shaded = r.render();
  ASSERT_EQ(shaded.width_px, r.compute_width_px());
  ASSERT_EQ(shaded.rgba.size(), size_t(4) * shaded.width_px * shaded.height_px);
  size_t lit = 0;
  for (size_t i = 0; i < shaded.rgba.size(); i += 4) lit += shaded.rgba[i] > 0;
  EXPECT_GT(lit, shaded.rgba.size() / 4 * 8 / 10);
  // Turned around, out of the room's open side: less of the model in view.
  Pose away = r.pose();
  for (int i : {0, 2, 4, 6, 8, 10}) away[i] = -away[i];
  const RgbaImage back = r.render(away);
  size_t lit_away = 0;
  for (size_t i = 0; i < back.rgba.size(); i += 4) lit_away += back.rgba[i] > 0;
  EXPECT_LT(lit_away, lit);
}

KFX_INSTANTIATE_BACKEND_MAP_TESTS(ApiRender);

/// The block map and the dense cube of the same frames give the same depth from a pose
/// neither raycast from (both hold the same TSDF values where the blocks are allocated).
TEST(ApiRenderMaps, BlockMapAndDenseCubeAgree) {
  Sequence sequence(kInput);
  std::vector<SequenceFrame> frames;
  SequenceFrame frame;
  while (sequence.next(frame) == ReadStatus::kOk) frames.push_back(frame);
  const auto make = [&](const char* kind) {
    return Reconstruction(
        Settings().backend("cpu").set("volume_resolution", "128").set("volume", kind), sequence);
  };
  Reconstruction dense = make("dense"), blocks = make("blocks");
  for (const auto& f : frames) {
    dense.process(f);
    blocks.process(f);
  }
  Pose pose = dense.trajectory()[4].T_world_cam;
  pose[3] += 0.05f;  // 5 cm aside: a pose no frame had
  const FloatImage d = dense.render_depth(pose), b = blocks.render_depth(pose);
  const Agreement a = agreement(d.values, b.values, 0.005f);
  EXPECT_GT(a.both, d.values.size() * 8 / 10);
  EXPECT_GT(a.close_share, 0.95) << "of " << a.both << " pixels";
}

}  // namespace
}  // namespace kfx
