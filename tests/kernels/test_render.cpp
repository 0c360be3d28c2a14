/// The render kernels (SLAMBench's renderDepth, renderTrack, renderVolume) on tiny inputs with
/// known colours, and `kfx run --renders` writing them at the render rate.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "io/png.hpp"
#include "kernels/render.hpp"
#include "support/cli_runner.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;

bool same(Rgba8 a, Rgba8 b) { return a.r == b.r && a.g == b.g && a.b == b.b && a.a == b.a; }
std::string str(Rgba8 c) {
  return std::to_string(c.r) + "," + std::to_string(c.g) + "," + std::to_string(c.b) + "," +
         std::to_string(c.a);
}

TEST(RenderDepth, ColoursAsSlambench) {
  HostImage<float> depth(5, 1);
  depth(0, 0) = 0.0f;   // hole: below near → white
  depth(1, 0) = 0.39f;  // below near → white
  depth(2, 0) = 4.5f;   // beyond far → black
  depth(3, 0) = 0.4f;   // h = 0: gs2rgb red end (0.75, 0.25, 0.25)
  depth(4, 0) = 2.2f;   // h = 0.5: sextant 3, fract 0 → (0.25, 0.75, 0.75)
  HostImage<Rgba8> out(5, 1);
  RenderDepthArgs a;
  a.depth_m = depth.view();
  a.out = out.view();
  for (int x = 0; x < 5; ++x) render_depth_pixel(x, 0, a);
  EXPECT_TRUE(same(out(0, 0), Rgba8{255, 255, 255, 255})) << str(out(0, 0));
  EXPECT_TRUE(same(out(1, 0), Rgba8{255, 255, 255, 255})) << str(out(1, 0));
  EXPECT_TRUE(same(out(2, 0), Rgba8{0, 0, 0, 255})) << str(out(2, 0));
  // 0.75·255 = 191.25 and 0.25·255 = 63.75, truncated as SLAMBench's casts.
  EXPECT_TRUE(same(out(3, 0), Rgba8{191, 63, 63, 255})) << str(out(3, 0));
  // (2.2 − 0.4) / 3.6 = 0.5 up to rounding: blue-green, either side of the sextant boundary.
  EXPECT_NEAR(out(4, 0).r, 63, 1);
  EXPECT_NEAR(out(4, 0).g, 191, 1);
  EXPECT_NEAR(out(4, 0).b, 191, 1);
}

TEST(RenderDepth, HueWheelIsContinuousAndStaysInRange) {
  // Between near and far the map never jumps: neighbouring depths give close colours.
  Rgba8 previous = depth_colour(0.0f);
  for (int i = 1; i <= 1000; ++i) {
    const Rgba8 c = depth_colour(i / 1000.0f);
    EXPECT_LE(std::abs(c.r - previous.r) + std::abs(c.g - previous.g) + std::abs(c.b - previous.b),
              6)
        << i;
    EXPECT_GE(std::min({c.r, c.g, c.b}), 63);
    EXPECT_LE(std::max({c.r, c.g, c.b}), 191);
    previous = c;
  }
}

TEST(RenderTrack, EachOutcomeHasItsColour) {
  const int outcomes[] = {kTrackInlier,
                          kTrackNoInputNormal,
                          kTrackOutsideReference,
                          kTrackNoReferenceNormal,
                          kTrackTooFar,
                          kTrackNormalMismatch,
                          0};
  const Rgba8 expected[] = {{128, 128, 128, 255}, {0, 0, 0, 255},   {255, 0, 0, 255},
                            {0, 255, 0, 255},     {0, 0, 255, 255}, {255, 255, 0, 255},
                            {255, 128, 128, 255}};
  HostImage<int8_t> outcome(7, 1);
  for (int x = 0; x < 7; ++x) outcome(x, 0) = static_cast<int8_t>(outcomes[x]);
  HostImage<Rgba8> out(7, 1);
  RenderTrackArgs a;
  a.outcome = outcome.view();
  a.out = out.view();
  for (int x = 0; x < 7; ++x) render_track_pixel(x, 0, a);
  for (int x = 0; x < 7; ++x)
    EXPECT_TRUE(same(out(x, 0), expected[x])) << x << ": " << str(out(x, 0));
  // A frame that was not tracked shows "not tracked" whatever the stale outcomes say.
  a.tracked_this_frame = false;
  for (int x = 0; x < 7; ++x) render_track_pixel(x, 0, a);
  for (int x = 0; x < 7; ++x) EXPECT_TRUE(same(out(x, 0), expected[6])) << x;
}

/// A 32³ volume of 2 m holding a wall at z = 1 m (tsdf = clamp((1 − z) / mu)), seen by a camera
/// at (1, 1, 0) looking down +z.
struct WallScene {
  int res = 32;
  float size_m = 2.0f;
  float mu_m = 0.1f;
  std::vector<Voxel> voxels;
  TrackingState state{};
  Intrinsics k{40.0f, 40.0f, 8.0f, 6.0f};  // a 16 × 12 camera
  explicit WallScene(bool empty = false) : voxels(static_cast<size_t>(res) * res * res) {
    const VolumeView v = view();
    for (int z = 0; z < res; ++z) {
      for (int y = 0; y < res; ++y) {
        for (int x = 0; x < res; ++x) {
          const float sdf =
              empty ? 1.0f : std::max(-1.0f, std::min(1.0f, (1.0f - v.centre_m(x, y, z).z) / mu_m));
          v.at(x, y, z) =
              Voxel{static_cast<int16_t>(sdf * kTsdfScale), empty ? int16_t{0} : int16_t{1}};
        }
      }
    }
    state.T_world_cam = Mat4f::translation(Vec3f{1.0f, 1.0f, 0.0f});
  }
  VolumeView view() { return VolumeView{voxels.data(), res, size_m, nullptr}; }
  HostImage<Rgba8> render(Vec3f light_m) {
    RenderParams p;
    p.volume_ray.k = k;
    p.volume_ray.step_m = size_m / res;
    p.volume_ray.large_step_m = 0.75f * mu_m;
    p.volume_ray.far_m = 8.0f;
    p.light_m = light_m;
    HostImage<Rgba8> out(16, 12);
    const RenderVolumeArgs a = make_render_volume_args(view(), out.view(), &state, p);
    for (int y = 0; y < 12; ++y) {
      for (int x = 0; x < 16; ++x) render_volume_pixel(x, y, a);
    }
    return out;
  }
};

TEST(RenderVolume, WallFacingTheLightIsWhiteAndLitFromTheSideIsAmbient) {
  WallScene scene;
  // Light behind the camera on the axis: the wall's normal (−z) points at it, n·l = 1, so the
  // shade saturates at 1 (1 + ambient clamped).
  const HostImage<Rgba8> front = scene.render(Vec3f{1.0f, 1.0f, -1.0f});
  EXPECT_TRUE(same(front(8, 6), Rgba8{255, 255, 255, 255})) << str(front(8, 6));
  // Light far to the side in the wall's plane: n·l ≈ 0, only the ambient 0.1 remains (25.5).
  const HostImage<Rgba8> side = scene.render(Vec3f{1000.0f, 1.0f, 1.0f});
  EXPECT_NEAR(side(8, 6).r, 25, 1);
  EXPECT_EQ(side(8, 6).r, side(8, 6).g);
  EXPECT_EQ(side(8, 6).a, 255);
  // Light in front of the wall's back side (z > 1): n·l < 0 is clamped to 0 → ambient.
  const HostImage<Rgba8> behind = scene.render(Vec3f{1.0f, 1.0f, 50.0f});
  EXPECT_NEAR(behind(8, 6).r, 25, 1);
}

TEST(RenderVolume, EmptyVolumeIsBlack) {
  WallScene scene(/*empty=*/true);
  const HostImage<Rgba8> out = scene.render(Vec3f{1.0f, 1.0f, -1.0f});
  for (const Rgba8& c : out.pixels()) EXPECT_TRUE(same(c, Rgba8{0, 0, 0, 255})) << str(c);
}

TEST(RunRenders, WritesThreePngsEveryRenderRateFramesAndTimesThemAsRendering) {
  const fs::path out = fs::temp_directory_path() / "kfx_run_renders";
  fs::remove_all(out);
  const auto r = test::run_kfx(
      "run synthetic:frames=11,width=160,height=120 --backend cpu -q -z 4 "
      "--renders --out " +
      out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (int f = 0; f < 11; ++f) {
    for (const char* kind : {"depth", "track", "volume"}) {
      char name[64];
      std::snprintf(name, sizeof(name), "%s_%06d.png", kind, f);
      const fs::path path = out / "renders" / name;
      EXPECT_EQ(fs::exists(path), f % 4 == 0) << path;
      if (f % 4 == 0 && fs::exists(path)) {
        const io::PngHeader h = io::read_png_header(path.string());
        EXPECT_EQ(h.width_px, 80);  // compute size: 160 × 120 at ratio 2
        EXPECT_EQ(h.height_px, 60);
        EXPECT_EQ(h.channels, 4);
      }
    }
  }
  // slambench.log: rendering is non-zero exactly on the rendered frames and stays out of
  // computation (= preprocessing + tracking + integration + raycasting).
  std::ifstream log(out / "slambench.log");
  std::string line;
  std::getline(log, line);
  int lines = 0;
  while (std::getline(log, line)) {
    std::istringstream fields(line);
    int frame;
    double acquisition, pre, track, integrate, raycast, render, computation;
    fields >> frame >> acquisition >> pre >> track >> integrate >> raycast >> render >> computation;
    ASSERT_TRUE(fields) << line;
    if (frame % 4 == 0) {
      EXPECT_GT(render, 0.0) << line;
    } else {
      EXPECT_EQ(render, 0.0) << line;
    }
    // Each of the five figures is printed rounded to 1 µs: the sum can be off by 2.5 µs.
    EXPECT_NEAR(computation, pre + track + integrate + raycast, 2.6e-6) << line;
    ++lines;
  }
  EXPECT_EQ(lines, 11);
  fs::remove_all(out);
}

}  // namespace
}  // namespace kfx
