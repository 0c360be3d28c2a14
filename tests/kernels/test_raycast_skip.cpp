/// Empty-space skipping in the raycast (kernels/raycast.hpp): the super-brick flags integration
/// sets, the conservative skip test and its fast-forward box, and bit-identical maps with the
/// skipping on and off.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "core/se3.hpp"
#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"
#include "kernels/raycast.hpp"
#include "support/integrate_test_support.hpp"

namespace kfx {
namespace {

const Intrinsics kK{120.0f, 120.0f, 40.0f, 30.0f};  // an 80×60 camera
constexpr int kW = 80, kH = 60;

/// A volume with both levels of flags, as FrameBuffers holds it.
struct FlaggedVolume {
  int res;
  float size_m;
  std::vector<Voxel> voxels;
  std::vector<uint8_t> bricks, supers;
  FlaggedVolume(int res_vox, float size)
      : res(res_vox),
        size_m(size),
        voxels(static_cast<size_t>(res) * res * res, Voxel{32766, 0}),
        bricks(
            static_cast<size_t>(bricks_per_side(res)) * bricks_per_side(res) * bricks_per_side(res),
            0),
        supers(static_cast<size_t>(super_bricks_per_side(res)) * super_bricks_per_side(res) *
                   super_bricks_per_side(res),
               0) {}
  VolumeView view() { return VolumeView{voxels.data(), res, size_m, bricks.data(), supers.data()}; }
};

TEST(RaycastSkip, MarkTouchedSetsTheBrickAndItsSuperBrick) {
  FlaggedVolume vol(128, 4.0f);
  const VolumeView v = vol.view();
  v.mark_touched(37, 5, 100);
  v.mark_touched(38, 6, 101);  // same brick: nothing new
  const int b = bricks_per_side(128), s = super_bricks_per_side(128);
  ASSERT_EQ(b, 16);
  ASSERT_EQ(s, 8);
  for (size_t i = 0; i < vol.bricks.size(); ++i) {
    EXPECT_EQ(vol.bricks[i], i == static_cast<size_t>(37 / 8 + (5 / 8) * b + (100 / 8) * b * b))
        << i;
  }
  for (size_t i = 0; i < vol.supers.size(); ++i) {
    EXPECT_EQ(vol.supers[i], i == static_cast<size_t>(37 / 16 + (5 / 16) * s + (100 / 16) * s * s))
        << i;
  }
  // A view without super-brick flags still marks its bricks.
  VolumeView bricks_only = v;
  bricks_only.super_brick_touched = nullptr;
  bricks_only.mark_touched(127, 127, 127);
  EXPECT_EQ(vol.bricks.back(), 1);
  EXPECT_EQ(vol.supers.back(), 0);
}

/// Integrates a box-and-slanted-wall scene with flying pixels and holes from three poses.
void integrate_scene(FlaggedVolume& vol) {
  HostImage<float> depth(kW, kH);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      float d = (x > 30 && x < 50 && y > 20 && y < 40) ? 1.6f : 3.0f + 0.01f * y;
      const float r = u(rng);
      if (r < 0.03f) d = 0.0f;                  // holes
      if (r > 0.98f) d = 0.5f + 2.5f * u(rng);  // flying pixels
      depth(x, y) = d;
    }
  }
  const double poses[3][6] = {{2.0, 2.0, 0.0, 0.0, 0.0, 0.0},
                              {1.7, 2.1, 0.2, 0.05, -0.1, 0.02},
                              {2.3, 1.9, 0.1, -0.04, 0.08, 0.0}};
  for (const auto& twist : poses) {
    TrackingState state{};
    state.T_world_cam = se3_exp(twist);
    test::integrate_every_column(
        test::frame_integrate_args(vol.view(), depth, kK, state, 0.1f, 3.6f));
  }
}

/// Vertex and normal maps of one raycast over `view` from `state`.
struct Maps {
  HostImage<Vec3f> vertex{kW, kH}, normal{kW, kH};
};

Maps raycast_maps(const RaycastParams& p, const VolumeView& view, const TrackingState& state) {
  Maps m;
  const RaycastArgs a{p, view, m.vertex.view(), m.normal.view(), &state};
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) raycast_pixel(x, y, a);
  }
  return m;
}

bool same_bits(const HostImage<Vec3f>& a, const HostImage<Vec3f>& b) {
  return std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(Vec3f)) == 0;
}

/// Poses: the integration views, outside the volume looking in, inside close to the surfaces
/// (rays start in touched bricks), looking out through the volume's faces, and random ones.
std::vector<std::vector<double>> march_poses() {
  std::vector<std::vector<double>> poses = {
      {2.0, 2.0, 0.0, 0.0, 0.0, 0.0},  {1.7, 2.1, 0.2, 0.05, -0.1, 0.02},
      {2.0, 2.0, -0.6, 0.0, 0.0, 0.0}, {2.0, 2.0, 1.1, 0.0, 0.0, 0.0},
      {2.0, 2.0, 2.6, 0.0, 0.0, 0.0},  {2.0, 2.0, 3.5, 0.0, 0.0, 0.0},
      {0.5, 3.5, 2.0, 0.0, 1.5, 0.0},  {2.0, 2.0, 3.9, 0.0, 3.14, 0.0}};
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 6; ++i) {
    poses.push_back({2.0 + 1.5 * u(rng), 2.0 + 1.5 * u(rng), 1.5 + 1.5 * u(rng), 0.8 * u(rng),
                     0.8 * u(rng), 3.0 * u(rng)});
  }
  return poses;
}

/// The march settings: exact (a voxel and 0.75 mu), an odd large step, the constant step, and
/// the two-value sample.
std::vector<RaycastParams> march_settings(const FlaggedVolume& vol) {
  std::vector<RaycastParams> settings(4);
  for (RaycastParams& p : settings) {
    p.k = kK;
    p.step_m = vol.size_m / vol.res;
    p.large_step_m = 0.075f;
  }
  settings[1].large_step_m = 0.0731f;
  settings[1].near_m = 0.05f;
  settings[2].constant_step_m = 0.05f;
  settings[3].interp = RaycastInterp::kTwoValue;
  return settings;
}

TEST(RaycastSkip, MapsAreBitIdenticalWithAndWithoutSkipping) {
  FlaggedVolume vol(128, 4.0f);  // 3.1 cm voxels, 50 cm super-bricks
  integrate_scene(vol);
  int touched_supers = 0;
  for (uint8_t f : vol.supers) touched_supers += f;
  ASSERT_GT(touched_supers, 0);
  ASSERT_LT(touched_supers, static_cast<int>(vol.supers.size()) / 2);  // mostly empty space

  const VolumeView full = vol.view();
  VolumeView bricks_only = full, no_skip = full;
  bricks_only.super_brick_touched = nullptr;
  no_skip.brick_touched = nullptr;
  no_skip.super_brick_touched = nullptr;

  const auto poses = march_poses();
  const auto settings = march_settings(vol);

  int hits = 0, misses = 0;
  for (size_t s = 0; s < settings.size(); ++s) {
    for (size_t i = 0; i < poses.size(); ++i) {
      TrackingState state{};
      state.T_world_cam = se3_exp(poses[i].data());
      set_reference_view(state, kK);
      const Maps a = raycast_maps(settings[s], full, state);
      const Maps b = raycast_maps(settings[s], bricks_only, state);
      const Maps c = raycast_maps(settings[s], no_skip, state);
      EXPECT_TRUE(same_bits(a.vertex, c.vertex)) << "setting " << s << ", pose " << i;
      EXPECT_TRUE(same_bits(a.normal, c.normal)) << "setting " << s << ", pose " << i;
      EXPECT_TRUE(same_bits(b.vertex, c.vertex)) << "setting " << s << ", pose " << i;
      EXPECT_TRUE(same_bits(b.normal, c.normal)) << "setting " << s << ", pose " << i;
      for (const Vec3f& v : c.vertex.pixels()) (v.z > 0.0f ? hits : misses) += 1;
    }
  }
  EXPECT_GT(hits, 20000);   // the poses see the surfaces ...
  EXPECT_GT(misses, 5000);  // ... and also empty space and the volume's faces
}

/// Hit parameter and point of every pixel's ray, marched reading `Batch` samples at a time.
template <int Batch>
std::vector<float> march_all(const RaycastParams& p, const VolumeView& view,
                             const TrackingState& state) {
  Maps m;
  const RaycastArgs a{p, view, m.vertex.view(), m.normal.view(), &state};
  std::vector<float> out;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const Mat4f& ray_view = state.raycast_view;
      Vec3f hit{0.0f, 0.0f, 0.0f};
      const float t = raycast_ray<Batch>(a, ray_view.translation_part(),
                                         rotate(ray_view, Vec3f{float(x), float(y), 1.0f}), hit);
      out.insert(out.end(), {t, hit.x, hit.y, hit.z});
    }
  }
  return out;
}

TEST(RaycastSkip, ReadingSamplesInBatchesGivesTheSameHits) {
  // The GPU reads kRaycastBatch samples of a touched stretch at once; any batch must give the
  // hits of one sample at a time, bit for bit, with and without empty-space skipping.
  FlaggedVolume vol(128, 4.0f);
  integrate_scene(vol);
  VolumeView no_skip = vol.view();
  no_skip.brick_touched = nullptr;
  no_skip.super_brick_touched = nullptr;
  int hits = 0;
  for (const RaycastParams& p : march_settings(vol)) {
    for (const auto& pose : march_poses()) {
      TrackingState state{};
      state.T_world_cam = se3_exp(pose.data());
      set_reference_view(state, kK);
      for (const VolumeView& view : {vol.view(), no_skip}) {
        const auto one = march_all<1>(p, view, state);
        EXPECT_EQ(one, march_all<2>(p, view, state));
        EXPECT_EQ(one, march_all<3>(p, view, state));
        EXPECT_EQ(one, march_all<kRaycastBatch>(p, view, state));
        for (size_t i = 0; i < one.size(); i += 4) hits += one[i] > 0.0f;
      }
    }
  }
  EXPECT_GT(hits, 20000);  // the rays reach the surfaces, so the batches are used
}

TEST(RaycastSkip, FastForwardKeepsEverySkippedSampleInUntouchedBricks) {
  // Random brick flags (super-brick flags their OR) in a 256³ volume of 4.8 m, as in the
  // benchmarks; random rays and steps. Every sample the march skips, tested or fast-forwarded,
  // must read (by the exact sample's own index arithmetic) only voxels of untouched bricks.
  FlaggedVolume vol(256, 4.8f);
  const int b = bricks_per_side(vol.res), sb = super_bricks_per_side(vol.res);
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int z = 0; z < b; ++z) {
    for (int y = 0; y < b; ++y) {
      for (int x = 0; x < b; ++x) {
        // Touched bricks in a few slabs and scattered, so large untouched regions remain.
        const bool touched = (z % 11 == 5 && y < 20) || (x % 13 == 7 && z > 10) || u(rng) < 0.01f;
        if (!touched) continue;
        vol.bricks[x + y * b + z * b * b] = 1;
        vol.supers[(x >> 1) + (y >> 1) * sb + (z >> 1) * sb * sb] = 1;
      }
    }
  }
  const VolumeView v = vol.view();
  const float vox_per_m = vol.res / vol.size_m, voxel_m = vol.size_m / vol.res;
  // True when the exact trilinear sample at p reads only voxels of untouched bricks.
  auto reads_untouched = [&](Vec3f p) {
    const float s[3] = {p.x * vol.res / vol.size_m - 0.5f, p.y * vol.res / vol.size_m - 0.5f,
                        p.z * vol.res / vol.size_m - 0.5f};
    int lo[3], hi[3];
    for (int i = 0; i < 3; ++i) {
      const int base = static_cast<int>(floorf(s[i]));
      lo[i] = std::max(base, 0);
      hi[i] = std::min(base + 1, vol.res - 1);
    }
    for (int z : {lo[2], hi[2]}) {
      for (int y : {lo[1], hi[1]}) {
        for (int x : {lo[0], hi[0]}) {
          if (vol.bricks[v.brick_index(x, y, z)]) return false;
        }
      }
    }
    return true;
  };
  long long tested = 0, forwarded = 0;
  for (int ray = 0; ray < 3000; ++ray) {
    const Vec3f origin{-1.0f + 6.8f * u(rng), -1.0f + 6.8f * u(rng), -1.0f + 6.8f * u(rng)};
    Vec3f direction{2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1};
    if (ray % 7 == 0) direction.y = 0.0f;  // parallel to a pair of faces
    if (ray % 11 == 0) direction.x = -0.0f;
    const Vec3f inv_dir{1.0f / direction.x, 1.0f / direction.y, 1.0f / direction.z};
    const float step = 0.002f + 0.1f * u(rng);
    // The ray's stretch inside the volume, as raycast_ray clips it.
    float t_near = 0.0f, t_far = 20.0f;
    const float o[3] = {origin.x, origin.y, origin.z}, inv[3] = {inv_dir.x, inv_dir.y, inv_dir.z};
    for (int i = 0; i < 3; ++i) {
      const float t0 = -o[i] * inv[i], t1 = (vol.size_m - o[i]) * inv[i];
      t_near = std::max(t_near, std::min(t0, t1));
      t_far = std::min(t_far, std::max(t0, t1));
    }
    for (float t = t_near; t < t_far;) {
      const Vec3f p = origin + direction * t;
      const UntouchedSample s = untouched_sample(v, p, vox_per_m);
      ++tested;
      if (!s.untouched) {
        t += step;
        continue;
      }
      ASSERT_TRUE(reads_untouched(p)) << "ray " << ray << " t " << t;
      const float t_end = std::min(untouched_box_exit_t(v, s, origin, inv_dir, voxel_m), t_far);
      for (t += step; t < t_end; t += step) {
        ++forwarded;
        ASSERT_TRUE(reads_untouched(origin + direction * t)) << "ray " << ray << " t " << t;
      }
    }
  }
  EXPECT_GT(forwarded, tested);  // most skipped samples were never tested one by one
}

}  // namespace
}  // namespace kfx
