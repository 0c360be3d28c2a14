/// Relocalisation (localise/relocaliser.hpp): the small depth image the views are coded from,
/// the keyframe database's ferns, harvest and query, a kidnapped camera found again on the
/// synthetic room, and the database saved with the map, loaded, refused when corrupt.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>

#include "api/internal.hpp"
#include "kernels/small_depth.hpp"
#include "kfx/kfx.hpp"
#include "localise/keyframe_database.hpp"
#include "localise/relocaliser.hpp"
#include "output/block_map_file.hpp"
#include "output/keyframe_section.hpp"
#include "output/volume_file.hpp"
#include "support/io_test_support.hpp"
#include "support/pose_compare.hpp"
#include "support/small_depth_support.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

// ---- the small depth image -------------------------------------------------------------

TEST(SmallDepth, SizesFollowTheComputeSize) {
  const SmallDepthParams a = small_depth_params(320, 240);
  EXPECT_EQ(a.factor, 8);
  EXPECT_EQ(a.width_px, 40);
  EXPECT_EQ(a.height_px, 30);
  const SmallDepthParams b = small_depth_params(80, 60);
  EXPECT_EQ(b.factor, 2);
  EXPECT_EQ(b.width_px, 40);
  const SmallDepthParams c = small_depth_params(640, 480);
  EXPECT_EQ(c.factor, 16);
  EXPECT_EQ(c.height_px, 30);
}

TEST(SmallDepth, AveragesValidDepthKeepsHolesAndBlursOverValidNeighboursOnly) {
  // 320×240: a plane at 2 m with a ramp in x, a hole (no depth) over the small pixel (5, 5)'s
  // block, and a block with only a few valid pixels at (20, 10).
  HostImage<float> depth(320, 240, 0.0f);
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) depth(x, y) = 2.0f + 0.001f * (x / 8);
  }
  for (int y = 40; y < 48; ++y) {
    for (int x = 40; x < 48; ++x) depth(x, y) = 0.0f;
  }
  for (int y = 80; y < 88; ++y) {
    for (int x = 160; x < 168; ++x) depth(x, y) = (x == 160 && y < 83) ? 3.0f : 0.0f;
  }
  const HostImage<uint16_t> s = test::small_depth_of(depth);
  ASSERT_EQ(s.width(), 40);
  EXPECT_EQ(s(5, 5), 0);    // the hole stays a hole
  EXPECT_EQ(s(20, 10), 0);  // 3 valid pixels of 64: below a quarter
  // Far from holes the blur of a linear ramp is the ramp: 2000 + x mm.
  EXPECT_EQ(s(30, 20), 2030);
  EXPECT_EQ(s(0, 0), 2000);  // at the border, over the neighbours that exist
  // Beside the hole the blur renormalises over the valid neighbours: no pull towards 0.
  EXPECT_GE(s(6, 5), 2005);
  EXPECT_LE(s(6, 5), 2007);
}

// ---- the keyframe database -------------------------------------------------------------

HostImage<uint16_t> wall(int tilt_mm_per_px, int offset_mm) {
  HostImage<uint16_t> image(40, 30);
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) {
      image(x, y) = static_cast<uint16_t>(offset_mm + tilt_mm_per_px * (x - 20) + 20 * y);
    }
  }
  return image;
}

TEST(KeyframeDatabase, FernCodesAreDeterministicAndReadTheThresholds) {
  const KeyframeDatabase a(40, 30, 500, 10), b(40, 30, 500, 10);
  ASSERT_EQ(a.tests().size(), 2000u);
  for (size_t i = 0; i < a.tests().size(); ++i) {
    EXPECT_EQ(a.tests()[i].x_px, b.tests()[i].x_px);
    EXPECT_EQ(a.tests()[i].threshold_mm, b.tests()[i].threshold_mm);
    EXPECT_LT(a.tests()[i].x_px, 40);
    EXPECT_LT(a.tests()[i].y_px, 30);
    EXPECT_GE(a.tests()[i].threshold_mm, KeyframeDatabase::kMinThresholdMm);
    EXPECT_LE(a.tests()[i].threshold_mm, KeyframeDatabase::kMaxThresholdMm);
  }
  const HostImage<uint16_t> image = wall(30, 2000);
  EXPECT_EQ(a.encode(image.view()), b.encode(image.view()));
  // Everything beyond every threshold: all bits set; nothing (holes): none.
  for (uint8_t c : a.encode(HostImage<uint16_t>(40, 30, 5000).view())) ASSERT_EQ(c, 15);
  for (uint8_t c : a.encode(HostImage<uint16_t>(40, 30, 0).view())) ASSERT_EQ(c, 0);
  // The fixed seed pins the tests: these values are those of every build.
  EXPECT_EQ(a.tests()[0].x_px, KeyframeDatabase(40, 30, 1, 1).tests()[0].x_px);
}

TEST(KeyframeDatabase, HarvestAndQueryFindTheNearestViewWithinCapacity) {
  KeyframeDatabase db(40, 30, 500, 3);
  const int offsets[3] = {1000, 2000, 3000};
  for (int i = 0; i < 3; ++i) {
    Keyframe k;
    k.T_world_cam = Mat4f::translation(Vec3f{static_cast<float>(i), 0, 0});
    k.frame = 10 * i;
    const HostImage<uint16_t> image = wall(10 * (i + 1), offsets[i]);
    EXPECT_TRUE(db.add(db.encode(image.view()), k, image.view()));
  }
  EXPECT_TRUE(db.full());
  EXPECT_FALSE(db.add(db.encode(wall(5, 1500).view()), Keyframe{}));
  EXPECT_EQ(db.size(), 3);
  // Each keyframe: its code, its record and its 40×30 small image.
  EXPECT_EQ(db.memory_bytes(),
            2000u * sizeof(FernTest) + 3u * (500u + sizeof(Keyframe) + 40u * 30u * 2u));
  EXPECT_EQ(db.memory_bytes(), db.capacity_bytes());
  // A view a little off the second keyframe's finds it first, with a small dissimilarity.
  const auto near = db.nearest(db.encode(wall(20, 2030).view()), 2);
  ASSERT_EQ(near.size(), 2u);
  EXPECT_EQ(near[0].keyframe, 1);
  EXPECT_EQ(db.keyframe(near[0].keyframe).frame, 10);
  EXPECT_LT(near[0].dissimilarity, 0.1f);
  EXPECT_GT(near[1].dissimilarity, near[0].dissimilarity);
  EXPECT_EQ(db.nearest(db.encode(wall(20, 2000).view()), 1)[0].dissimilarity, 0.0f);
}

TEST(KeyframeDatabase, SerialisesAndParsesBackAndRefusesCorruptBytes) {
  KeyframeDatabase db(40, 30, 64, 5);
  db.add(db.encode(wall(10, 1500).view()), Keyframe{Mat4f::translation(Vec3f{1, 2, 3}), 7});
  db.add(db.encode(wall(30, 2500).view()), Keyframe{Mat4f::identity(), 9});
  const std::vector<uint8_t> bytes = db.serialise();
  const KeyframeDatabase back = KeyframeDatabase::parse(bytes.data(), bytes.size(), "f", 1);
  EXPECT_EQ(back.size(), 2);
  EXPECT_EQ(back.capacity(), 2);  // raised to the stored count
  EXPECT_EQ(back.serialise(), bytes);
  EXPECT_EQ(back.keyframe(0).frame, 7);
  EXPECT_EQ(back.keyframe(0).T_world_cam.translation_part().z, 3.0f);
  io::test::expect_error(
      [&] { KeyframeDatabase::parse(bytes.data(), bytes.size() - 1, "map.kfxtsdf", 0); },
      {"map.kfxtsdf", "keyframe database", "truncated"});
  std::vector<uint8_t> bad = bytes;
  bad[20] = 0xff;  // the first fern test's x
  bad[21] = 0xff;
  io::test::expect_error([&] { KeyframeDatabase::parse(bad.data(), bad.size(), "m", 0); },
                         {"m:", "outside"});
  bad = bytes;
  bad[bytes.size() - 64 + 3] = 0x7f;  // the last pose's first element: no longer a rotation
  io::test::expect_error([&] { KeyframeDatabase::parse(bad.data(), bad.size(), "m", 0); },
                         {"m:", "keyframe 1"});
}

// ---- the relocaliser's codes ----------------------------------------------------------

TEST(Relocaliser, HarvestsAndLooksUpTheCodesOfTheSubmittedInputWithNoImageFromTheBackend) {
  RelocaliserSettings settings;
  settings.view_jump_dissimilarity = 1.1f;  // these views differ more than a view jump's share
  Relocaliser r(settings, 40, 30);
  const HostImage<uint16_t> a = wall(10, 1000), b = wall(30, 3000);
  // Two frames in flight, as `kfx run` keeps them: each is observed with its own code.
  EXPECT_FALSE(r.submitted_view(0, a.view()));
  EXPECT_FALSE(r.submitted_view(1, b.view()));
  RelocaliserObservation o;
  o.tracking_ran = o.tracked = o.good = true;
  for (int f = 0; f < 2; ++f) {
    o.frame = f;
    o.T_world_cam = Mat4f::translation(Vec3f{0.05f * static_cast<float>(f), 0, 0});
    EXPECT_FALSE(r.observe(o));
  }
  const KeyframeDatabase& db = r.keyframes();
  ASSERT_EQ(db.size(), 2);
  for (int f = 0; f < 2; ++f) {
    const auto nearest = db.nearest(db.encode((f == 0 ? a : b).view()), 1);
    ASSERT_EQ(nearest.size(), 1u);
    EXPECT_EQ(db.keyframe(nearest[0].keyframe).frame, f);
    EXPECT_EQ(nearest[0].dissimilarity, 0.0f);
  }
  // The camera moves on in b's view (no new keyframe: the same code), then fails in a's: the
  // attempts try the last good pose, then the keyframes nearest the failed frame's submitted
  // view, a's (frame 0's) first.
  EXPECT_FALSE(r.submitted_view(2, b.view()));
  o.frame = 2;
  o.T_world_cam = Mat4f::translation(Vec3f{0.1f, 0, 0});
  r.observe(o);
  EXPECT_EQ(db.size(), 2);
  EXPECT_FALSE(r.submitted_view(3, a.view()));
  o.frame = 3;
  o.tracked = o.good = false;
  r.observe(o);
  EXPECT_TRUE(r.lost());
  std::vector<float> tried_x_m;
  for (int f = 4; f < 7; ++f) {
    EXPECT_FALSE(r.submitted_view(f, a.view()));
    const RelocaliserPlan plan = r.plan();
    ASSERT_TRUE(plan.attempt) << "frame " << f;
    EXPECT_FALSE(plan.integrate);
    tried_x_m.push_back(plan.T_world_cam.m[0][3]);
    o.frame = f;
    o.attempt = true;
    r.observe(o);
  }
  EXPECT_EQ(tried_x_m, (std::vector<float>{0.1f, 0.0f, 0.05f}));
}

/// A tracked, good frame at `x_m` with the ICP's figures given.
RelocaliserObservation tracked_at(int frame, float x_m, double inliers = 0.7, double rms_m = 0.003,
                                  double too_far = 0.002) {
  RelocaliserObservation o;
  o.tracking_ran = o.tracked = o.good = true;
  o.frame = frame;
  o.T_world_cam = Mat4f::translation(Vec3f{x_m, 0, 0});
  o.inlier_fraction = inliers;
  o.residual_rms_m = rms_m;
  o.too_far_fraction = too_far;
  return o;
}

/// A relocaliser with one keyframe, at x 0 m (frame 0), tracking at frame 1 with `a`'s view.
Relocaliser tracking_one_keyframe(const HostImage<uint16_t>& a) {
  Relocaliser r(RelocaliserSettings{}, 40, 30);
  for (int f = 0; f < 2; ++f) {
    r.submitted_view(f, a.view());
    r.observe(tracked_at(f, 0.01f * f));
  }
  EXPECT_EQ(r.keyframes().size(), 1);
  return r;
}

TEST(Relocaliser, ATrackedFrameThatMovedFurtherThanACameraCanIsAViewJump) {
  const HostImage<uint16_t> a = wall(10, 1000);
  Relocaliser r = tracking_one_keyframe(a);
  // A step of 3 cm is motion; 70 cm in one frame is the ICP converging in a view it was not in.
  r.submitted_view(2, a.view());
  r.submitted_view(3, a.view());
  r.observe(tracked_at(2, 0.04f));
  EXPECT_FALSE(r.lost());
  r.observe(tracked_at(3, 0.74f));
  EXPECT_TRUE(r.lost());
  EXPECT_TRUE(r.lost_at(3));
  EXPECT_FALSE(r.lost_at(2));
  // The frame in flight behind it tracked on from its pose: lost too, and no verification.
  r.submitted_view(4, a.view());
  const RelocaliserPlan plan = r.plan();
  ASSERT_TRUE(plan.attempt);
  EXPECT_FALSE(plan.integrate);
  EXPECT_EQ(plan.T_world_cam.m[0][3], 0.0f) << "the keyframe, not the suspect last pose";
}

TEST(Relocaliser, ATrackedFrameWhoseFitFellApartIsAViewJumpAndAWorseFitAloneIsNot) {
  const HostImage<uint16_t> a = wall(10, 1000);
  {
    Relocaliser r = tracking_one_keyframe(a);
    r.submitted_view(2, a.view());
    // Residual 1.5 times, inliers 0.7 times the previous frame's: a harder view, still tracking.
    r.observe(tracked_at(2, 0.02f, 0.49, 0.0045));
    EXPECT_FALSE(r.lost());
    r.submitted_view(3, a.view());
    // Residual 5 times, inliers 0.3 times: the fit fell apart.
    r.observe(tracked_at(3, 0.03f, 0.15, 0.0225));
    EXPECT_TRUE(r.lost_at(3));
  }
  {
    // Either alone is not enough.
    Relocaliser r = tracking_one_keyframe(a);
    r.submitted_view(2, a.view());
    r.observe(tracked_at(2, 0.02f, 0.2, 0.003));
    r.submitted_view(3, a.view());
    r.observe(tracked_at(3, 0.03f, 0.2, 0.03));
    EXPECT_FALSE(r.lost());
  }
}

TEST(Relocaliser, ACandidateWhoseFitFellApartVerifiesNothingOneThatFitsAsTrackingDidIsFound) {
  const HostImage<uint16_t> a = wall(10, 1000);
  Relocaliser r = tracking_one_keyframe(a);  // good frames: inliers 0.7, residual 3 mm
  r.submitted_view(2, a.view());
  RelocaliserObservation failed = tracked_at(2, 0.02f, 0.1, 0.02);
  failed.tracked = failed.good = false;
  r.observe(failed);
  ASSERT_TRUE(r.lost());
  int f = 3;
  // Candidates that pass the accept test with a residual 5 times and inliers 0.35 times a
  // good frame's: never found, however many frames agree.
  for (; f < 9; ++f) {
    r.submitted_view(f, a.view());
    RelocaliserObservation o = tracked_at(f, 0.02f, 0.25, 0.015);
    o.good = false;
    o.attempt = r.plan().attempt;
    EXPECT_FALSE(r.observe(o)) << "frame " << f;
    EXPECT_TRUE(r.lost());
  }
  // A fit like tracking's (residual 1.3 times, inliers 0.7 times): verified over 3 frames.
  int found_at = -1;
  for (; f < 15 && found_at < 0; ++f) {
    r.submitted_view(f, a.view());
    RelocaliserObservation o = tracked_at(f, 0.02f, 0.5, 0.004);
    o.good = false;
    o.attempt = r.plan().attempt;
    if (r.observe(o)) found_at = f;
  }
  EXPECT_GE(found_at, 9);
  EXPECT_LE(found_at, 12);
  EXPECT_FALSE(r.lost());
}

/// Tracking at frame 1 as tracking_one_keyframe(), then lost at frame 2 (the accept test failed).
Relocaliser lost_at_frame_two(const HostImage<uint16_t>& a) {
  Relocaliser r = tracking_one_keyframe(a);
  r.submitted_view(2, a.view());
  RelocaliserObservation failed = tracked_at(2, 0.02f, 0.1, 0.02);
  failed.tracked = failed.good = false;
  r.observe(failed);
  EXPECT_TRUE(r.lost());
  return r;
}

TEST(Relocaliser, AnAttemptThatEndedFarFromItsCandidateVerifiesNothingNorDoFramesTrackedOnFromIt) {
  const HostImage<uint16_t> a = wall(10, 1000);
  Relocaliser r = lost_at_frame_two(a);
  // Each attempt's ICP ends 0.8 m from the candidate it started at, with a fit as good as
  // tracking's; the frame submitted behind it tracks on from there, as well. Neither counts.
  int f = 3;
  for (; f < 15; f += 2) {
    r.submitted_view(f, a.view());
    const RelocaliserPlan attempt = r.plan();
    ASSERT_TRUE(attempt.attempt) << "frame " << f;
    r.submitted_view(f + 1, a.view());
    ASSERT_FALSE(r.plan().attempt) << "an attempt is in flight";
    RelocaliserObservation o = tracked_at(f, attempt.T_world_cam.m[0][3] + 0.8f);
    o.attempt = true;
    EXPECT_FALSE(r.observe(o)) << "frame " << f;
    EXPECT_FALSE(r.observe(tracked_at(f + 1, attempt.T_world_cam.m[0][3] + 0.81f)))
        << "frame " << f + 1;
    EXPECT_TRUE(r.lost());
  }
  // Attempts that end 10 cm from their candidate: verified over 3 frames.
  int found_at = -1;
  for (; f < 25 && found_at < 0; ++f) {
    r.submitted_view(f, a.view());
    const RelocaliserPlan plan = r.plan();
    RelocaliserObservation o = tracked_at(f, 0.1f);
    o.attempt = plan.attempt;
    if (r.observe(o)) found_at = f;
  }
  EXPECT_GE(found_at, 17);
  EXPECT_LE(found_at, 18);
  EXPECT_FALSE(r.lost());
}

TEST(Relocaliser, ACandidateThatPairsMuchOfItsViewWithMapPointsFarAwayVerifiesNothing) {
  const HostImage<uint16_t> a = wall(10, 1000);
  Relocaliser r = lost_at_frame_two(a);  // good frames: 0.2 % of pixels paired too far away
  int f = 3;
  // Inliers and residual as good tracking's, but 5 % of the pixels paired with map points
  // beyond the ICP's distance threshold (25 times the good frames' share): a wall that fits at
  // a wrong pose while the rest of the view lies elsewhere. Never found.
  for (; f < 9; ++f) {
    r.submitted_view(f, a.view());
    RelocaliserObservation o = tracked_at(f, 0.02f, 0.7, 0.003, 0.05);
    o.attempt = r.plan().attempt;
    EXPECT_FALSE(r.observe(o)) << "frame " << f;
    EXPECT_TRUE(r.lost());
  }
  // The same fit with 0.4 % paired too far away (below the 1 % floor): found.
  int found_at = -1;
  for (; f < 15 && found_at < 0; ++f) {
    r.submitted_view(f, a.view());
    RelocaliserObservation o = tracked_at(f, 0.02f, 0.7, 0.003, 0.004);
    o.attempt = r.plan().attempt;
    if (r.observe(o)) found_at = f;
  }
  EXPECT_GE(found_at, 9);
  EXPECT_LE(found_at, 12);
  EXPECT_FALSE(r.lost());
}

TEST(Relocaliser, AnAttemptWhosePairedPixelsFitIsFoundThoughTheMapCoversPartOfItsView) {
  const HostImage<uint16_t> a = wall(10, 1000);
  Relocaliser r = lost_at_frame_two(a);  // good frames: inliers 0.7, 0.2 % paired too far
  int f = 3;
  // Inliers 0.3 of the view (0.43 times a good frame's), and of the pixels the map covers 0.3
  // fit while 0.3 pair with a normal that disagrees: half the paired pixels fit. Never found.
  for (; f < 9; ++f) {
    r.submitted_view(f, a.view());
    RelocaliserObservation o = tracked_at(f, 0.02f, 0.3, 0.003, 0.002);
    o.bad_normal_fraction = 0.3;
    o.attempt = r.plan().attempt;
    EXPECT_FALSE(r.observe(o)) << "frame " << f;
    EXPECT_TRUE(r.lost());
  }
  // The same inliers with the rest of the view beyond the map (paired with nothing): the
  // paired pixels fit as a good frame's do, and the camera is found.
  int found_at = -1;
  for (; f < 15 && found_at < 0; ++f) {
    r.submitted_view(f, a.view());
    RelocaliserObservation o = tracked_at(f, 0.02f, 0.3, 0.003, 0.002);
    o.bad_normal_fraction = 0.01;
    o.attempt = r.plan().attempt;
    if (r.observe(o)) found_at = f;
  }
  EXPECT_GE(found_at, 9);
  EXPECT_LE(found_at, 12);
  EXPECT_FALSE(r.lost());
}

TEST(Relocaliser, ADoubtfulViewAndTheFrameBehindItWaitForItsTrackingBeforeIntegrating) {
  const HostImage<uint16_t> a = wall(10, 1000);
  // b: a's view with a band of its columns moved far, changing a share of the ferns between the
  // doubt and the jump thresholds.
  const RelocaliserSettings settings;
  const KeyframeDatabase db(40, 30, settings.fern_count, 1);
  const std::vector<uint8_t> code_a = db.encode(a.view());
  HostImage<uint16_t> b;
  float share = 0;
  for (int columns = 1; columns <= 40; ++columns) {
    b = wall(10, 1000);
    for (int y = 0; y < 30; ++y) {
      for (int x = 0; x < columns; ++x) b.view()(x, y) = 3900;
    }
    const std::vector<uint8_t> code_b = db.encode(b.view());
    int differ = 0;
    for (size_t i = 0; i < code_a.size(); ++i) differ += code_a[i] != code_b[i];
    share = static_cast<float>(differ) / static_cast<float>(code_a.size());
    if (share > settings.view_doubt_dissimilarity + 0.03f) break;
  }
  ASSERT_GT(share, settings.view_doubt_dissimilarity);
  ASSERT_LT(share, settings.view_jump_dissimilarity);
  Relocaliser r = tracking_one_keyframe(a);
  EXPECT_TRUE(r.plan().integrate);
  EXPECT_FALSE(r.submitted_view(2, b.view()));
  EXPECT_FALSE(r.plan().integrate) << "the doubtful frame";
  EXPECT_FALSE(r.submitted_view(3, b.view()));
  EXPECT_FALSE(r.plan().integrate) << "the frame submitted behind it";
  r.observe(tracked_at(2, 0.03f));  // it tracked as a frame does: no jump
  EXPECT_FALSE(r.lost());
  EXPECT_FALSE(r.submitted_view(4, b.view()));
  EXPECT_TRUE(r.plan().integrate);
  r.observe(tracked_at(3, 0.04f));
  r.observe(tracked_at(4, 0.05f));
  EXPECT_FALSE(r.lost());
}

// ---- the relocaliser on the synthetic room ---------------------------------------------

/// The room at 4x speed: a loop every 75 frames. The jump looks at a side wall from frame 85 to
/// 105; when it ends the camera is back on its loop 0.3 m from where it was lost, at a place
/// the first loop mapped (and harvested keyframes at).
const char* kKidnap = "synthetic:frames=115,width=160,height=120,speed=4,jump=85-105";
const char* kLoop = "synthetic:frames=125,width=160,height=120,speed=4";
constexpr int kJumpLast = 105;
constexpr int kLoopFrames = 75;
/// The goals of relocalisation: found within this many frames of the view returning, at a
/// pose this close to where the uninterrupted run's tracking puts it.
constexpr int kFramesToFind = 5;
constexpr float kFoundWithinM = 0.05f;
constexpr float kFoundWithinDeg = 5.0f;

Settings reloc_settings(bool blocks, bool relocalise = true) {
  Settings s = Settings().backend("cpu").set("volume_resolution", "64");
  if (relocalise) s.set("relocalise", "on");
  if (blocks) s.set("volume", "blocks").set("voxel_size_m", "0.066").set("map_budget_mb", "16");
  return s;
}

/// The uninterrupted run of kLoop, per map kind, run once and shared by the tests below: its
/// poses are where tracking against this map puts the camera (the map's own drift included,
/// several centimetres at 64³), and its map saved after the first loop.
struct UncutRun {
  std::vector<Pose> poses;
  std::string map_path;
  KeyframeDatabase keyframes;
};

const UncutRun& uncut_run(bool blocks) {
  static std::map<bool, UncutRun> runs;
  auto found = runs.find(blocks);
  if (found != runs.end()) return found->second;
  UncutRun& run = runs[blocks];
  const auto dir = test::fresh_test_dir(blocks ? "kfx_reloc_blocks_" : "kfx_reloc_dense_");
  run.map_path = (dir / (blocks ? "map.kfxblocks" : "map.kfxtsdf")).string();
  Sequence sequence(kLoop);
  Reconstruction r(reloc_settings(blocks), sequence);
  const auto frames = test::read_all_frames(kLoop);
  for (int i = 0; i < static_cast<int>(frames.size()); ++i) {
    run.poses.push_back(r.process(frames[i]).T_world_cam);
    if (i + 1 == kLoopFrames) {
      r.save_map(run.map_path);
      run.keyframes = ReconstructionAccess::pipeline(r).relocaliser()->keyframes();
    }
  }
  return run;
}

class Relocalisation : public ::testing::TestWithParam<bool> {};

TEST_P(Relocalisation, AKidnappedCameraIsFoundWithinFiveFramesNearTheTruth) {
  const bool blocks = GetParam();
  const auto frames = test::read_all_frames(kKidnap);
  Sequence sequence(kKidnap);
  Reconstruction run(reloc_settings(blocks), sequence);
  int found_at = -1;
  for (int i = 0; i < static_cast<int>(frames.size()); ++i) {
    const FrameResult r = run.process(frames[i]);
    // The jump's first frame too: the view jump is seen from its input depth before it is
    // submitted, so it is neither fused nor tracked from the old pose.
    if (i >= 85 && i <= kJumpLast) {
      EXPECT_FALSE(r.integrated) << "frame " << i << " in the jump was integrated";
      EXPECT_FALSE(r.relocalised) << "frame " << i << ": relocalised while looking elsewhere";
    }
    if (r.relocalised && found_at < 0 && i > kJumpLast) found_at = i;
    if (i > kJumpLast && found_at < 0) {
      EXPECT_FALSE(r.integrated) << "frame " << i << " integrated before the camera was found";
      EXPECT_EQ(r.tracking_quality, TrackingQuality::kLost) << "frame " << i;
    }
  }
  ASSERT_GT(found_at, kJumpLast) << "never relocalised";
  EXPECT_LE(found_at, kJumpLast + kFramesToFind);
  float metres = 0, degrees = 0;
  const UncutRun& uncut = uncut_run(blocks);
  test::pose_error(run.trajectory()[found_at].T_world_cam, uncut.poses[found_at], metres, degrees);
  EXPECT_LT(metres, kFoundWithinM);
  EXPECT_LT(degrees, kFoundWithinDeg);
  // And it keeps tracking from there, where the uninterrupted run is.
  EXPECT_TRUE(run.trajectory().back().tracked);
  test::pose_error(run.pose(), uncut.poses[frames.size() - 1], metres, degrees);
  EXPECT_LT(metres, kFoundWithinM);
}

TEST(Relocalisation, ALossBeforeAnyFrameTrackedTriesWhereTheCameraStarted) {
  // At 80x60 compute on 1 cm blocks the room's first tracked frame (4) is lost, before any frame
  // has tracked: the relocaliser's only candidate is the last good pose, which is the start.
  const char* input = "synthetic:frames=8,width=160,height=120,speed=2";
  Sequence sequence(input);
  Reconstruction run(Settings()
                         .backend("cpu")
                         .set("relocalise", "on")
                         .set("volume", "blocks")
                         .set("voxel_size_m", "0.01"),
                     sequence);
  const Pose start = run.pose();
  for (const SequenceFrame& frame : test::read_all_frames(input)) {
    const FrameResult r = run.process(frame);
    float metres = 0, degrees = 0;
    test::pose_error(r.T_world_cam, start, metres, degrees);
    // The camera moves 9 cm in eight frames, and tracking this coarse slides up to 0.6 m for a
    // frame; a pose from nowhere (the identity, or memory never written) lies metres off, or is
    // not a number.
    EXPECT_LT(metres, 1.0f) << "frame " << r.index;
  }
  EXPECT_GT(ReconstructionAccess::pipeline(run).relocaliser()->figures().attempts, 0)
      << "the loss this test is about did not happen";
}

INSTANTIATE_TEST_SUITE_P(DenseAndBlocks, Relocalisation, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "blocks" : "dense"; });

// ---- the database saved with the map ---------------------------------------------------

class RelocalisationMap : public ::testing::TestWithParam<bool> {};

TEST_P(RelocalisationMap, SavedWithTheMapReloadedAndUsedToLocateANewRun) {
  const bool blocks = GetParam();
  const auto frames = test::read_all_frames(kLoop);
  Sequence sequence(kLoop);
  const UncutRun& uncut = uncut_run(blocks);
  const std::string& path = uncut.map_path;
  ASSERT_GT(uncut.keyframes.size(), 2);
  const std::optional<KeyframeDatabase> read = blocks ? output::read_block_map_file(path).keyframes
                                                      : output::read_volume_file(path).keyframes;
  ASSERT_TRUE(read.has_value());
  EXPECT_EQ(read->serialise(), uncut.keyframes.serialise());

  // A new run given only frames from the middle of the second loop, far from the saved camera
  // (the end of the first): lost at first, it locates itself from the keyframes, integrating
  // nothing before.
  Reconstruction loaded(reloc_settings(blocks), sequence);
  const LoadedMap info = loaded.load_map(path);
  EXPECT_EQ(info.note, "");
  const int start = 112;
  int found_at = -1;
  for (int i = start; i < static_cast<int>(frames.size()); ++i) {
    const FrameResult r = loaded.process(frames[i]);
    if (found_at < 0) {
      EXPECT_FALSE(r.integrated) << "frame " << i;
    }
    if (r.relocalised && found_at < 0) found_at = i;
  }
  ASSERT_GE(found_at, start) << "never relocalised";
  EXPECT_LE(found_at, start + kFramesToFind);
  float metres = 0, degrees = 0;
  test::pose_error(loaded.trajectory()[found_at - start].T_world_cam, uncut.poses[found_at], metres,
                   degrees);
  EXPECT_LT(metres, kFoundWithinM);
  EXPECT_LT(degrees, kFoundWithinDeg);
}

INSTANTIATE_TEST_SUITE_P(DenseAndBlocks, RelocalisationMap, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "blocks" : "dense"; });

TEST(RelocalisationMapFile, AnOlderFileLoadsAndSaysItCannotRelocalise) {
  const auto dir = test::fresh_test_dir("kfx_reloc_map_");
  const auto frames = test::read_all_frames(kLoop);
  Sequence sequence(kLoop);
  Reconstruction first(reloc_settings(false, false), sequence);
  for (int i = 0; i < 10; ++i) first.process(frames[i]);
  const std::string path = (dir / "map.kfxtsdf").string();
  first.save_map(path);  // relocalise off: no keyframe section (format version 3 or 4)
  {
    std::ifstream in(path, std::ios::binary);
    char header[12];
    in.read(header, 12);
    EXPECT_TRUE(header[8] == 3 || header[8] == 4) << int(header[8]);
  }
  Reconstruction loaded(reloc_settings(false), sequence);
  const LoadedMap info = loaded.load_map(path);
  EXPECT_TRUE(info.pose_restored);
  EXPECT_NE(info.note.find("cannot relocalise"), std::string::npos) << info.note;
  // From the saved camera it still verifies before integrating.
  for (int i = 10; i < 13; ++i) EXPECT_FALSE(loaded.process(frames[i]).integrated) << i;
}

TEST(RelocalisationMapFile, ACorruptOrTruncatedKeyframeSectionIsAnErrorNamingTheFile) {
  const auto dir = test::fresh_test_dir("kfx_reloc_map_");
  const auto frames = test::read_all_frames(kLoop);
  Sequence sequence(kLoop);
  for (bool blocks : {false, true}) {
    Reconstruction r(reloc_settings(blocks), sequence);
    for (int i = 0; i < 6; ++i) r.process(frames[i]);
    const std::string path = (dir / (blocks ? "map.kfxblocks" : "map.kfxtsdf")).string();
    r.save_map(path);
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t section = bytes.find("KFXKEYF");
    ASSERT_NE(section, std::string::npos);
    const std::string truncated = path + ".truncated", corrupt = path + ".corrupt",
                      length = path + ".length";
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() - 3);
    std::string c = bytes;
    c[section] = 'X';
    std::ofstream(corrupt, std::ios::binary) << c;
    std::string l = bytes;
    l[section + 8] ^= 1;
    std::ofstream(length, std::ios::binary) << l;
    Reconstruction loader(reloc_settings(blocks), sequence);
    io::test::expect_error([&] { loader.load_map(truncated); }, {truncated, "keyframe"});
    io::test::expect_error([&] { loader.load_map(corrupt); }, {corrupt, "keyframe section"});
    io::test::expect_error([&] { loader.load_map(length); }, {length, "keyframe section"});
  }
}

}  // namespace
}  // namespace kfx
