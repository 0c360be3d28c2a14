/// The fused preprocess and pyramid bodies (what the CUDA backend runs with cuda_fused_preprocess
/// on) against the separate bodies (what the CPU backend runs): the same values (to kHostUlps,
/// see there; the GPU's bits are compared exactly by the parity tests) in every output,
/// on random depth images of awkward sizes and on a real frame, for every preprocess setting.
/// The fused side is composed here as the CUDA kernels compose it: 32×8 tiles, a halo of
/// recomputed neighbour values, then the pixels of the tile from those. The GPU parity tests
/// (tests/backend/test_backend_parity.cpp) check the CUDA kernels themselves on a device.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "io/reader.hpp"
#include "kernels/preprocess.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

// The CUDA kernels' tile (cuda_kernels.cuh: kTileWidthPx × kTileHeightPx).
constexpr int kTileW = 32;
constexpr int kTileH = 8;

uint32_t bits(float v) {
  uint32_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

/// Distance in units in the last place between two finite floats of any sign (NaN: far).
int64_t ulps_apart(float a, float b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b) ? 0 : INT64_MAX;
  auto ordered = [](float v) {  // the bits as a monotone integer line through ±0
    const int64_t i = static_cast<int32_t>(bits(v));
    return i < 0 ? INT64_C(-2147483648) - i : i;
  };
  const int64_t d = ordered(a) - ordered(b);
  return d < 0 ? -d : d;
}

/// Values further apart than this count as different. The GPU's bits are compared exactly by
/// the parity tests on a device; here on the host the two call sites of one body are compiled
/// separately, and a host compiler may contract their multiply-adds differently (seen: 1 ulp
/// on the device machine's host with -march=native). A composition error (a wrong neighbour,
/// tile or halo) moves a value by millimetres, thousands of ulps.
constexpr int64_t kHostUlps = 4;

/// Pixels of `a` and `b` more than kHostUlps apart (any of the three components for vectors).
int differing_pixels(const HostImage<float>& a, const HostImage<float>& b) {
  int n = 0;
  for (size_t i = 0; i < a.pixels().size(); ++i)
    n += ulps_apart(a.pixels()[i], b.pixels()[i]) > kHostUlps;
  return n;
}
int differing_pixels(const HostImage<Vec3f>& a, const HostImage<Vec3f>& b) {
  int n = 0;
  for (size_t i = 0; i < a.pixels().size(); ++i) {
    const Vec3f u = a.pixels()[i], v = b.pixels()[i];
    n += ulps_apart(u.x, v.x) > kHostUlps || ulps_apart(u.y, v.y) > kHostUlps ||
         ulps_apart(u.z, v.z) > kHostUlps;
  }
  return n;
}

/// A depth image in millimetres with what the filters must get right: smooth slopes, steps
/// wider than the range terms, holes (single pixels and runs, also at the borders), and depths
/// beyond a cut-off.
HostImage<uint16_t> random_depth_mm(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise_mm(-15, 15);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  HostImage<uint16_t> d(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      int mm = 900 + 7 * x + 3 * y + noise_mm(rng);
      if (x > w / 3 && x < w / 2 && y > h / 4) mm += 1200;  // a step of 1.2 m
      if ((x + 2 * y) % 37 < 3) mm -= 250;                  // narrow ridges of 0.25 m
      if (unit(rng) < 0.08f || x == 0 || (y == h - 1 && x % 5 < 3)) mm = 0;  // holes
      if (unit(rng) < 0.01f) mm = 6000 + noise_mm(rng);                      // far outliers
      d(x, y) = static_cast<uint16_t>(std::max(mm, 0));
    }
  }
  return d;
}

/// Bilateral settings of the configuration's kind: `mode`, radius, zero padding, cut-off.
BilateralParams bilateral_params(BilateralMode mode, int radius_px, bool zero_padded,
                                 float max_depth_m) {
  BilateralParams p = make_bilateral_params(mode, radius_px, 4.0f, 0.1f, zero_padded);
  p.max_depth_m = max_depth_m;
  return p;
}

struct PreprocessResult {
  HostImage<float> depth_m, filtered_m;
  float max_depth_m = 0.0f;
};

/// As the CPU backend: mm_to_m_pixel over the image, then bilateral_pixel over it.
PreprocessResult preprocess_separately(const HostImage<uint16_t>& in_mm, int ratio,
                                       const BilateralParams& p) {
  const int w = in_mm.width() / ratio, h = in_mm.height() / ratio;
  PreprocessResult r{HostImage<float>(w, h), HostImage<float>(w, h)};
  const MmToMArgs mm{in_mm.view(), r.depth_m.view(), ratio, p.max_depth_m};
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) r.max_depth_m = std::max(r.max_depth_m, mm_to_m_pixel(x, y, mm));
  }
  const BilateralArgs b{p, r.depth_m.view(), r.filtered_m.view()};
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) bilateral_pixel(x, y, b);
  }
  return r;
}

/// As preprocess_kernel: per 32×8 tile, preprocess_input_m over the tile and a halo of the
/// radius into a tile buffer, then preprocess_pixel from it. Outputs start as NaN, so a pixel
/// the fused pass missed differs.
PreprocessResult preprocess_fused(const HostImage<uint16_t>& in_mm, int ratio,
                                  const BilateralParams& p) {
  const int w = in_mm.width() / ratio, h = in_mm.height() / ratio;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  PreprocessResult r{HostImage<float>(w, h, nan), HostImage<float>(w, h, nan)};
  const PreprocessArgs a{p, MmToMArgs{in_mm.view(), r.depth_m.view(), ratio, p.max_depth_m},
                         r.filtered_m.view()};
  const int radius = p.radius_px, tile_w = kTileW + 2 * radius, tile_h = kTileH + 2 * radius;
  std::vector<float> tile(static_cast<size_t>(tile_w) * tile_h);
  for (int y0 = 0; y0 < h; y0 += kTileH) {
    for (int x0 = 0; x0 < w; x0 += kTileW) {
      for (int ty = 0; ty < tile_h; ++ty) {
        for (int tx = 0; tx < tile_w; ++tx) {
          tile[ty * tile_w + tx] = preprocess_input_m(x0 + tx - radius, y0 + ty - radius, a);
        }
      }
      for (int y = y0; y < std::min(y0 + kTileH, h); ++y) {
        for (int x = x0; x < std::min(x0 + kTileW, w); ++x) {
          const int cx = x - x0 + radius, cy = y - y0 + radius;
          const float d = preprocess_pixel(
              x, y, a, [&](int i, int j) { return tile[(cy + j) * tile_w + cx + i]; });
          r.max_depth_m = std::max(r.max_depth_m, d);
        }
      }
    }
  }
  return r;
}

void expect_same_preprocess(const HostImage<uint16_t>& in_mm, int ratio, const BilateralParams& p,
                            const std::string& what) {
  const PreprocessResult separate = preprocess_separately(in_mm, ratio, p);
  const PreprocessResult fused = preprocess_fused(in_mm, ratio, p);
  EXPECT_EQ(differing_pixels(separate.depth_m, fused.depth_m), 0) << what;
  EXPECT_EQ(differing_pixels(separate.filtered_m, fused.filtered_m), 0) << what;
  EXPECT_EQ(bits(separate.max_depth_m), bits(fused.max_depth_m)) << what;
  // The comparison means something: the filter changed pixels (radius 0 keeps them), some
  // depth survived.
  if (p.radius_px > 0)
    EXPECT_GT(differing_pixels(separate.depth_m, separate.filtered_m), 0) << what;
  EXPECT_GT(separate.max_depth_m, 0.0f) << what;
}

/// Every preprocess setting the configuration offers, on `in_mm` at ratio 1 and 2.
void expect_same_preprocess_for_every_setting(const HostImage<uint16_t>& in_mm, float cut_off_m) {
  for (int ratio : {1, 2}) {
    for (bool zero_padded : {false, true}) {
      for (float max_depth_m : {0.0f, cut_off_m}) {
        for (int radius : {0, 1, 2, 3, kMaxBilateralRadius}) {
          expect_same_preprocess(
              in_mm, ratio,
              bilateral_params(BilateralMode::kExact, radius, zero_padded, max_depth_m),
              "exact r=" + std::to_string(radius) + " ratio=" + std::to_string(ratio) +
                  " zero_padded=" + std::to_string(zero_padded) +
                  " max_depth_m=" + std::to_string(max_depth_m));
        }
        expect_same_preprocess(
            in_mm, ratio, bilateral_params(BilateralMode::kSpatial3x3, 2, zero_padded, max_depth_m),
            "spatial3x3 ratio=" + std::to_string(ratio) + " zero_padded=" +
                std::to_string(zero_padded) + " max_depth_m=" + std::to_string(max_depth_m));
      }
    }
  }
}

TEST(FusedPreprocess, SameBitsAsMmToMThenBilateralOnRandomDepth) {
  // 166×122 at ratio 1 and 83×61 at ratio 2: neither divides into 32×8 tiles.
  expect_same_preprocess_for_every_setting(random_depth_mm(166, 122, 7), 2.0f);
}

/// The first depth frame of a shared TUM sequence in millimetres (empty when missing).
HostImage<uint16_t> first_real_frame(const std::string& sequence) {
  if (!test::shared_exists("data/" + sequence)) return {};
  auto reader = io::open_reader(test::shared_path("data/" + sequence));
  io::Frame frame;
  if (reader->next(frame).status != io::ReadStatus::kOk) return {};
  return frame.depth_mm;
}

TEST(FusedPreprocess, SameBitsAsMmToMThenBilateralOnARealFrame) {
  const HostImage<uint16_t> frame = first_real_frame("tum_fr1_xyz");
  if (frame.empty()) GTEST_SKIP() << "../shared/data/tum_fr1_xyz is missing";
  const BilateralParams exact = bilateral_params(BilateralMode::kExact, 2, false, 0.0f);
  expect_same_preprocess(frame, 2, exact, "tum_fr1_xyz frame 0, exact, ratio 2");
  const BilateralParams cut = bilateral_params(BilateralMode::kSpatial3x3, 2, true, 1.5f);
  expect_same_preprocess(frame, 2, cut, "tum_fr1_xyz frame 0, spatial3x3, zero padded, 1.5 m");
  expect_same_preprocess(frame, 1, exact, "tum_fr1_xyz frame 0, exact, ratio 1");
}

struct Pyramid {
  std::vector<HostImage<float>> depth_m;
  std::vector<HostImage<Vec3f>> vertex, normal;
};

Pyramid empty_pyramid(const HostImage<float>& level0_m, int levels, float fill) {
  Pyramid p;
  const Vec3f fill3{fill, fill, fill};
  for (int l = 0; l < levels; ++l) {
    const int w = level0_m.width() >> l, h = level0_m.height() >> l;
    p.depth_m.push_back(l == 0 ? level0_m : HostImage<float>(w, h, fill));
    p.vertex.emplace_back(w, h, fill3);
    p.normal.emplace_back(w, h, fill3);
  }
  return p;
}

/// As the CPU backend: half_sample_pixel level after level, then depth_to_vertex_pixel and
/// vertex_to_normal_pixel at each level.
Pyramid pyramid_separately(const HostImage<float>& level0_m, const PyramidParams& pp, int levels) {
  Pyramid p = empty_pyramid(level0_m, levels, 0.0f);
  for (int l = 1; l < levels; ++l) {
    const HalfSampleArgs a{p.depth_m[l - 1].view(), p.depth_m[l].view(), pp.half_sample_range_m};
    for (int y = 0; y < a.out_m.height; ++y) {
      for (int x = 0; x < a.out_m.width; ++x) half_sample_pixel(x, y, a);
    }
  }
  for (int l = 0; l < levels; ++l) {
    const DepthToVertexArgs v{p.depth_m[l].view(), p.vertex[l].view(),
                              pp.level_intrinsics[l].inverse_matrix()};
    const VertexToNormalArgs n{p.vertex[l].view(), p.normal[l].view(),
                               pp.level_intrinsics[l].handedness()};
    for (int y = 0; y < v.vertex.height; ++y) {
      for (int x = 0; x < v.vertex.width; ++x) depth_to_vertex_pixel(x, y, v);
    }
    for (int y = 0; y < v.vertex.height; ++y) {
      for (int x = 0; x < v.vertex.width; ++x) vertex_to_normal_pixel(x, y, n);
    }
  }
  return p;
}

/// As pyramid_kernel: per level and 32×8 tile, pyramid_vertex over the tile and a one-pixel
/// halo (inside the image) into a tile buffer, storing only the tile's own pixels, then
/// pyramid_normal_pixel from it. Outputs start as NaN, so a pixel the fused pass missed differs.
Pyramid pyramid_fused(const HostImage<float>& level0_m, const PyramidParams& pp, int levels) {
  Pyramid p = empty_pyramid(level0_m, levels, std::numeric_limits<float>::quiet_NaN());
  PyramidArgs a;
  a.levels = levels;
  a.half_sample_range_m = pp.half_sample_range_m;
  for (int l = 0; l < levels; ++l) {
    a.depth_m[l] = p.depth_m[l].view();
    a.vertex[l] = p.vertex[l].view();
    a.normal[l] = p.normal[l].view();
    a.inverse_k[l] = pp.level_intrinsics[l].inverse_matrix();
    a.handedness[l] = pp.level_intrinsics[l].handedness();
  }
  constexpr int kW = kTileW + 2, kH = kTileH + 2;
  std::vector<Vec3f> tile(kW * kH);
  for (int l = 0; l < levels; ++l) {
    const int w = a.vertex[l].width, h = a.vertex[l].height;
    for (int y0 = 0; y0 < h; y0 += kTileH) {
      for (int x0 = 0; x0 < w; x0 += kTileW) {
        for (int ty = 0; ty < kH; ++ty) {
          for (int tx = 0; tx < kW; ++tx) {
            const int x = x0 + tx - 1, y = y0 + ty - 1;
            if (x < 0 || y < 0 || x >= w || y >= h) continue;
            const bool own = tx >= 1 && tx <= kTileW && ty >= 1 && ty <= kTileH;
            tile[ty * kW + tx] = pyramid_vertex(l, x, y, a, own);
          }
        }
        for (int y = y0; y < std::min(y0 + kTileH, h); ++y) {
          for (int x = x0; x < std::min(x0 + kTileW, w); ++x) {
            pyramid_normal_pixel(
                l, x, y, a, [&](int u, int v) { return tile[(v - y0 + 1) * kW + u - x0 + 1]; });
          }
        }
      }
    }
  }
  return p;
}

void expect_same_pyramid(const HostImage<float>& level0_m, const Intrinsics& k, int levels,
                         const std::string& what) {
  PyramidParams pp;
  for (int l = 0; l < levels; ++l) {
    pp.level_intrinsics[l] = k.scaled_down(static_cast<float>(1 << l));
  }
  const Pyramid separate = pyramid_separately(level0_m, pp, levels);
  const Pyramid fused = pyramid_fused(level0_m, pp, levels);
  for (int l = 0; l < levels; ++l) {
    const std::string at = what + ", level " + std::to_string(l);
    EXPECT_EQ(differing_pixels(separate.depth_m[l], fused.depth_m[l]), 0) << at;
    EXPECT_EQ(differing_pixels(separate.vertex[l], fused.vertex[l]), 0) << at;
    EXPECT_EQ(differing_pixels(separate.normal[l], fused.normal[l]), 0) << at;
    // The comparison means something: valid and invalid normals both occur.
    int valid = 0;
    for (const Vec3f& n : separate.normal[l].pixels()) valid += n.x != kInvalidNormal;
    EXPECT_GT(valid, 0) << at;
    EXPECT_LT(valid, separate.normal[l].width() * separate.normal[l].height()) << at;
  }
}

TEST(FusedPyramid, SameBitsAsLevelByLevelOnRandomDepth) {
  // Level 0 from the separate preprocess of a random image: 166×122, then 83×61, 41×30, 20×15.
  const PreprocessResult pre = preprocess_separately(
      random_depth_mm(166, 122, 11), 1, bilateral_params(BilateralMode::kExact, 2, false, 0.0f));
  const Intrinsics k{150.0f, 150.0f, 82.5f, 60.5f};
  for (int levels = 1; levels <= kMaxPyramidLevels; ++levels) {
    expect_same_pyramid(pre.filtered_m, k, levels, std::to_string(levels) + " levels");
  }
  // ICL-NUIM's negative fy (handedness −1), and unfiltered depth with its hard edges.
  const Intrinsics k_icl{150.0f, -150.0f, 82.5f, 60.5f};
  expect_same_pyramid(pre.filtered_m, k_icl, kMaxPyramidLevels, "negative fy");
  expect_same_pyramid(pre.depth_m, k, kMaxPyramidLevels, "unfiltered");
}

TEST(FusedPyramid, SameBitsAsLevelByLevelOnARealFrame) {
  const HostImage<uint16_t> frame = first_real_frame("tum_fr1_xyz");
  if (frame.empty()) GTEST_SKIP() << "../shared/data/tum_fr1_xyz is missing";
  const PreprocessResult pre =
      preprocess_separately(frame, 2, bilateral_params(BilateralMode::kExact, 2, false, 0.0f));
  const Intrinsics k{258.65f, 258.25f, 159.3f, 127.65f};  // TUM fr1 at 320×240
  expect_same_pyramid(pre.filtered_m, k, 3, "tum_fr1_xyz frame 0");
  expect_same_pyramid(pre.filtered_m, k, kMaxPyramidLevels, "tum_fr1_xyz frame 0, 4 levels");
}

}  // namespace
}  // namespace kfx
