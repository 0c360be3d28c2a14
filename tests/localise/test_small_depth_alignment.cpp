/// A lost view aligned to its candidate keyframe before the attempt
/// (localise/small_depth_alignment.hpp, RelocaliserSettings::align_candidates): the alignment
/// itself on a rendered room, the relocaliser's attempts starting where the alignment puts the
/// camera, and the keyframes' small images saved with the map's keyframe section and read back
/// (the section without them still read).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "core/se3.hpp"
#include "kernels/small_depth.hpp"
#include "localise/keyframe_database.hpp"
#include "localise/located_pose.hpp"
#include "localise/relocaliser.hpp"
#include "localise/small_depth_alignment.hpp"
#include "output/keyframe_section.hpp"
#include "support/io_test_support.hpp"
#include "support/small_depth_support.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

constexpr int kWidthPx = 320, kHeightPx = 240;
const Intrinsics kComputeK{260.0f, 260.0f, 159.5f, 119.5f};

/// Distance along the ray from `o` in direction `d` to the first surface of a room: the inside
/// of a box 4 m wide, 2.6 m high and 4.5 m deep around the origin, with a cabinet (a smaller box)
/// standing against its back wall and a table top, so that no direction of motion is unseen.
float room_hit_m(Vec3f o, Vec3f d) {
  float best = 1e9f;
  const float lo[3] = {-1.8f, -1.2f, -1.0f}, hi[3] = {2.2f, 1.4f, 3.5f};
  const float od[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
  // Inside the room: the nearest wall the ray leaves through.
  for (int a = 0; a < 3; ++a) {
    if (dd[a] > 0) best = std::min(best, (hi[a] - od[a]) / dd[a]);
    if (dd[a] < 0) best = std::min(best, (lo[a] - od[a]) / dd[a]);
  }
  // Boxes seen from outside: slab entry.
  const float boxes[2][6] = {{-1.2f, -0.2f, 2.6f, -0.4f, 1.4f, 3.5f},
                             {0.4f, 0.5f, 1.3f, 1.4f, 0.6f, 2.2f}};
  for (const auto& b : boxes) {
    float t0 = 0, t1 = 1e9f;
    for (int a = 0; a < 3 && t0 <= t1; ++a) {
      if (dd[a] == 0) {
        if (od[a] < b[a] || od[a] > b[a + 3]) t0 = 2e9f;
        continue;
      }
      float ta = (b[a] - od[a]) / dd[a], tb = (b[a + 3] - od[a]) / dd[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    }
    if (t0 <= t1 && t0 > 0) best = std::min(best, t0);
  }
  return best;
}

/// The small depth image the relocaliser codes, of the room seen from `T_world_cam`: depth at
/// the compute size, then the kernels' block mean and blur.
HostImage<uint16_t> small_view(const Mat4f& T_world_cam) {
  HostImage<float> depth(kWidthPx, kHeightPx, 0.0f);
  const Vec3f o = T_world_cam.translation_part();
  for (int y = 0; y < kHeightPx; ++y) {
    for (int x = 0; x < kWidthPx; ++x) {
      const Vec3f ray_cam{(x - kComputeK.cx) / kComputeK.fx, (y - kComputeK.cy) / kComputeK.fy,
                          1.0f};
      const float t = room_hit_m(o, rotate(T_world_cam, ray_cam));
      depth.view()(x, y) = t < 1e8f ? t : 0.0f;  // t along a ray of unit z: the depth
    }
  }
  return test::small_depth_of(depth);
}

Intrinsics small_k() {
  return small_depth_intrinsics(kComputeK, small_depth_params(kWidthPx, kHeightPx));
}

/// The camera turned by `pan_deg` about its y axis and `tilt_deg` about its x axis, then moved
/// by `t` (its own axes).
Mat4f moved(float pan_deg, float tilt_deg, Vec3f t) {
  const double k = 3.14159265358979323846 / 180.0;
  const double twist[6] = {t.x, t.y, t.z, tilt_deg * k, pan_deg * k, 0};
  return se3_exp(twist);
}

/// The keyframe's camera, and the lost view's: 18° panned, 6° tilted and 15 cm away from it,
/// as far as the nearest keyframes by fern code were from lost views of the real sequences.
const Mat4f kKeyframePose = Mat4f::translation(Vec3f{0.1f, 0.0f, 0.2f});
const Mat4f kRelative = moved(18.0f, -6.0f, Vec3f{0.12f, 0.04f, -0.08f});

TEST(SmallDepthAlignment, TheSmallImagesIntrinsicsSitAtTheBlocksCentres) {
  const SmallDepthParams p = small_depth_params(kWidthPx, kHeightPx);
  const Intrinsics k = small_depth_intrinsics(kComputeK, p);
  EXPECT_FLOAT_EQ(k.fx, kComputeK.fx / 8.0f);
  // The compute principal point 159.5 is the centre of blocks 19 and 20 (pixels 152–167).
  EXPECT_FLOAT_EQ(k.cx, 19.5f);
  EXPECT_FLOAT_EQ(k.cy, 14.5f);
}

TEST(SmallDepthAlignment, FindsAViewTurnedAndMovedFromTheKeyframe) {
  const HostImage<uint16_t> key = small_view(kKeyframePose);
  const HostImage<uint16_t> view = small_view(kKeyframePose * kRelative);
  const SmallDepthAlignment a = align_small_depth(view.view(), key.view(), small_k());
  float metres = 0, degrees = 0;
  pose_difference(a.T_keyframe_view, kRelative, metres, degrees);
  EXPECT_LT(metres, 0.04f);
  EXPECT_LT(degrees, 2.0f);
  EXPECT_GT(a.inlier_fraction, 0.4f);
  // The same view aligns to itself where it is.
  const SmallDepthAlignment self = align_small_depth(key.view(), key.view(), small_k());
  pose_difference(self.T_keyframe_view, Mat4f::identity(), metres, degrees);
  EXPECT_LT(metres, 0.005f);
  EXPECT_LT(degrees, 0.3f);
  EXPECT_GT(self.inlier_fraction, 0.95f);
}

TEST(SmallDepthAlignment, AViewWithNoDepthFindsNothing) {
  const HostImage<uint16_t> key = small_view(kKeyframePose);
  const HostImage<uint16_t> empty(key.width(), key.height(), 0);
  const SmallDepthAlignment a = align_small_depth(empty.view(), key.view(), small_k());
  EXPECT_EQ(a.view_points, 0);
  EXPECT_EQ(a.inlier_fraction, 0.0f);
}

/// The poses a lost relocaliser tries for the view seen from kKeyframePose · kRelative, with one
/// keyframe harvested at kKeyframePose.
std::vector<Mat4f> attempts_for_the_lost_view(bool align) {
  RelocaliserSettings settings;
  settings.align_candidates = align;
  const SmallDepthParams p = small_depth_params(kWidthPx, kHeightPx);
  Relocaliser r(settings, p.width_px, p.height_px);
  r.set_small_intrinsics(small_k());
  r.trust_pose(kKeyframePose);
  const HostImage<uint16_t> key = small_view(kKeyframePose);
  const HostImage<uint16_t> lost = small_view(kKeyframePose * kRelative);
  RelocaliserObservation o;
  o.tracking_ran = o.tracked = o.good = true;
  o.T_world_cam = kKeyframePose;
  o.inlier_fraction = 0.7;
  o.residual_rms_m = 0.003;
  for (int f = 0; f < 2; ++f) {
    r.submitted_view(f, key.view());
    o.frame = f;
    r.observe(o);
  }
  EXPECT_EQ(r.keyframes().size(), 1);
  std::vector<Mat4f> tried;
  for (int f = 2; f < 8; ++f) {
    r.submitted_view(f, lost.view());
    const RelocaliserPlan plan = r.plan();
    if (plan.attempt) tried.push_back(plan.T_world_cam);
    o.frame = f;
    o.attempt = plan.attempt;
    o.tracked = o.good = false;
    r.observe(o);
  }
  EXPECT_TRUE(r.lost());
  return tried;
}

/// Whether one of `tried` lies within 5 cm and 5° of the lost view's true pose.
bool one_near_the_truth(const std::vector<Mat4f>& tried) {
  return std::any_of(tried.begin(), tried.end(), [](const Mat4f& pose) {
    float metres = 0, degrees = 0;
    pose_difference(pose, kKeyframePose * kRelative, metres, degrees);
    return metres < 0.05f && degrees < 5.0f;
  });
}

TEST(RelocaliserAlignment, AnAttemptFromAKeyframeStartsWhereTheLostViewAlignsToIt) {
  const std::vector<Mat4f> aligned = attempts_for_the_lost_view(true);
  ASSERT_FALSE(aligned.empty());
  EXPECT_TRUE(one_near_the_truth(aligned));
  // Without the alignment every attempt starts at the keyframe's (or the last good) pose, 19°
  // from the view.
  const std::vector<Mat4f> raw = attempts_for_the_lost_view(false);
  ASSERT_FALSE(raw.empty());
  EXPECT_FALSE(one_near_the_truth(raw));
}

TEST(RelocaliserAlignment, AKeyframeWithoutItsImageIsTriedAtItsOwnPose) {
  RelocaliserSettings settings;
  settings.align_candidates = true;
  const SmallDepthParams p = small_depth_params(kWidthPx, kHeightPx);
  KeyframeDatabase db(p.width_px, p.height_px, settings.fern_count, 10);
  const HostImage<uint16_t> key = small_view(kKeyframePose);
  db.add(db.encode(key.view()), Keyframe{kKeyframePose, 0});  // as a first-version section
  Relocaliser r(settings, p.width_px, p.height_px);
  r.set_small_intrinsics(small_k());
  r.adopt_keyframes(db);
  const HostImage<uint16_t> lost = small_view(kKeyframePose * kRelative);
  const Mat4f start = r.candidate_pose(0, lost.view());
  EXPECT_EQ(std::memcmp(start.m, kKeyframePose.m, sizeof(start.m)), 0);
  EXPECT_EQ(r.figures().alignments, 0);
}

TEST(KeyframeSection, CarriesTheSmallImagesAndStillReadsTheVersionWithout) {
  const auto dir = test::fresh_test_dir("kfx_keyframe_images_");
  const SmallDepthParams p = small_depth_params(kWidthPx, kHeightPx);
  const HostImage<uint16_t> key = small_view(kKeyframePose);
  for (const bool images : {true, false}) {
    KeyframeDatabase db(p.width_px, p.height_px, 64, 10);
    db.add(db.encode(key.view()), Keyframe{kKeyframePose, 3},
           images ? key.view() : ImageView<const uint16_t>{});
    EXPECT_EQ(db.has_images(), images);
    const std::string path = (dir / (images ? "v2.bin" : "v1.bin")).string();
    {
      std::FILE* f = std::fopen(path.c_str(), "wb");
      ASSERT_NE(f, nullptr);
      output::write_keyframe_section(f, db);
      std::fclose(f);
    }
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    const auto bytes = static_cast<uint64_t>(in.tellg());
    in.seekg(0);
    const KeyframeDatabase back = output::read_keyframe_section(in, bytes, path);
    ASSERT_EQ(back.size(), 1);
    EXPECT_EQ(back.has_images(), images);
    const ImageView<const uint16_t> image = back.image(0);
    ASSERT_EQ(image.data != nullptr, images);
    if (images) {
      for (int y = 0; y < p.height_px; ++y) {
        for (int x = 0; x < p.width_px; ++x) ASSERT_EQ(image(x, y), key.view()(x, y));
      }
    }
    // Cut short by one byte: an error naming the file.
    std::vector<char> raw(bytes);
    in.clear();
    in.seekg(0);
    in.read(raw.data(), static_cast<std::streamsize>(bytes));
    const std::string cut = path + ".cut";
    std::ofstream(cut, std::ios::binary).write(raw.data(), static_cast<std::streamsize>(bytes - 1));
    io::test::expect_error(
        [&] {
          std::ifstream c(cut, std::ios::binary);
          output::read_keyframe_section(c, bytes - 1, cut);
        },
        {cut, "keyframe section"});
  }
}

}  // namespace
}  // namespace kfx
