/// Backend parity: the CUDA backend against the CPU backend, stage by stage on identical inputs
/// and over a whole synthetic sequence, plus run-to-run repeatability of each backend. The CUDA
/// tests skip (with the reason) where this build has no CUDA backend or no GPU is present.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "backend/backend.hpp"
#include "io/reader.hpp"
#include "kernels/preprocess.hpp"
#include "support/sequence_runner.hpp"

namespace kfx {
namespace {

// Tolerances, each with its reason:
// - filtered depth: expf differs by an ulp or two between libm and CUDA → 1e-5 m.
constexpr float kFilteredDepthTol_m = 1e-5f;
// - volume: a voxel can round to the neighbouring int16 tsdf (1/32766), and where a projection
//   lands exactly on a pixel boundary the two backends can pick neighbouring pixels; allow a
//   tiny fraction of voxels to differ by more than 2 units.
constexpr int kTsdfUnitTol = 2;
constexpr double kMaxVoxelMismatchFraction = 1e-4;
// - raycast: vertices within a millimetre, except a tiny fraction of silhouette pixels.
constexpr float kVertexTol_m = 1e-3f;
constexpr double kMaxPixelMismatchFraction = 2e-3;
// - one tracked frame: both backends iterate to the same minimum up to float summation order;
//   the per-frame bound (median 1 mm) applies (measured on an H200: 0.10 mm).
constexpr float kTrackedPoseTol_m = 1e-3f;
// - trajectories (issue: median ≤ 1 mm, 95th percentile ≤ 1 cm): test::kBackendMedianTol_m and
//   kBackendP95Tol_m, checked by test::expect_backends_agree (support/sequence_runner.hpp).

#define KFX_REQUIRE_CUDA()                                  \
  do {                                                      \
    std::string why_not;                                    \
    if (!cuda_available(&why_not)) GTEST_SKIP() << why_not; \
  } while (0)

BackendSetup small_setup() {
  BackendSetup s;
  s.input_width_px = 320;
  s.input_height_px = 240;
  s.compute_ratio = 1;
  s.pyramid_levels = 3;
  s.volume_res_vox = 128;
  s.volume_size_m = 4.0f;
  return s;
}

const Intrinsics kK{262.5f, 262.5f, 159.5f, 119.5f};

HostImage<uint16_t> scene_depth() {
  HostImage<uint16_t> d(320, 240);
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) {
      double z = 2.6 + 0.002 * (x - 160) + 0.001 * y;
      if (x > 100 && x < 200 && y > 60 && y < 150) z = 1.6 + 0.0015 * x;
      if ((x * 7 + y * 13) % 97 == 0) z = 0;  // holes
      d(x, y) = static_cast<uint16_t>(z * 1000);
    }
  }
  return d;
}

/// The preprocess settings of `exact` (bilateral radius 2, clamped borders, no cut-off).
BilateralParams exact_bilateral() {
  BilateralParams pre;
  for (int i = 0; i < 5; ++i) pre.spatial_weight[i] = std::exp(-((i - 2) * (i - 2)) / 32.0f);
  return pre;
}

/// Drives one backend through a frame of a given kind by hand.
TrackingState run_frame(Backend& b, const HostImage<uint16_t>& depth, bool track, bool always,
                        bool render = false, const BilateralParams& pre = exact_bilateral()) {
  PyramidParams pyr;
  for (int l = 0; l < kMaxPyramidLevels; ++l) {
    pyr.level_intrinsics[l] = kK.scaled_down(static_cast<float>(1 << l));
  }
  IntegrateParams integ;
  integ.k = kK;
  RaycastParams ray;
  ray.k = kK;
  ray.step_m = 4.0f / 128;
  AcceptParams accept;
  accept.compute_pixels = 320 * 240;
  b.upload_depth(depth.view());
  b.begin_frame((track ? 1 : 0) | 2 | (always ? 4 : 0) | 8 | (render ? 16 : 0));
  b.preprocess(pre);
  if (track) {
    b.build_pyramid(pyr);
    b.begin_tracking(IcpGuessParams{});
    const int iterations[3] = {10, 5, 4};
    for (int level = 2; level >= 0; --level) {
      for (int i = 0; i < iterations[level]; ++i) b.icp_iteration(level, IcpParams{});
    }
    b.accept_or_revert(accept);
  } else {
    b.skip_tracking();
  }
  b.integrate(integ, always);
  b.raycast(ray);
  if (render) {
    RenderParams params;
    params.tracked_this_frame = track;
    params.volume_ray = ray;
    params.volume_ray.far_m = 8.0f;
    b.render(params);
  }
  b.end_frame();
  return b.read_state();
}

/// The CPU and CUDA backends from the same start pose, each after fusing `depth` four times
/// (untracked frames, integration forced): identical volumes up to the backends' rounding.
struct BackendPair {
  std::unique_ptr<Backend> cpu, gpu;
};
BackendPair backends_after_fusing(const HostImage<uint16_t>& depth) {
  BackendPair pair{make_backend(BackendKind::kCpu, small_setup()),
                   make_backend(BackendKind::kCuda, small_setup())};
  const Mat4f start = Mat4f::translation(Vec3f{2.0f, 2.0f, 0.0f});
  for (Backend* b : {pair.cpu.get(), pair.gpu.get()}) {
    b->reset(start);
    for (int f = 0; f < 4; ++f) run_frame(*b, depth, false, true);
  }
  return pair;
}

TEST(BackendParity, StagesAgreeOnIdenticalInputs) {
  KFX_REQUIRE_CUDA();
  const HostImage<uint16_t> depth = scene_depth();
  const BackendPair pair = backends_after_fusing(depth);
  Backend &cpu = *pair.cpu, &gpu = *pair.gpu;
  const DebugMaps c = cpu.read_maps(), g = gpu.read_maps();
  int depth_mismatch = 0, filtered_mismatch = 0;
  for (int i = 0; i < 320 * 240; ++i) {
    depth_mismatch += c.depth_m.pixels()[i] != g.depth_m.pixels()[i];
    filtered_mismatch +=
        std::fabs(c.filtered_m.pixels()[i] - g.filtered_m.pixels()[i]) > kFilteredDepthTol_m;
  }
  EXPECT_EQ(depth_mismatch, 0);
  EXPECT_EQ(filtered_mismatch, 0);
  const auto vc = cpu.read_volume(), vg = gpu.read_volume();
  long long voxel_mismatch = 0, touched = 0;
  for (size_t i = 0; i < vc.size(); ++i) {
    touched += vc[i].weight > 0;
    voxel_mismatch +=
        std::abs(vc[i].tsdf - vg[i].tsdf) > kTsdfUnitTol || vc[i].weight != vg[i].weight;
  }
  EXPECT_GT(touched, 10000);
  EXPECT_LE(voxel_mismatch, kMaxVoxelMismatchFraction * vc.size());
  int pixel_mismatch = 0, hits = 0;
  for (int i = 0; i < 320 * 240; ++i) {
    const Vec3f a = c.ref_vertex.pixels()[i], b = g.ref_vertex.pixels()[i];
    hits += a.z > 0;
    pixel_mismatch += length(a - b) > kVertexTol_m;
  }
  EXPECT_GT(hits, 320 * 240 / 2);
  EXPECT_LE(pixel_mismatch, kMaxPixelMismatchFraction * 320 * 240);
  // A tracked frame from a slightly shifted depth: both converge to the same pose.
  HostImage<uint16_t> moved = depth;
  for (auto& v : moved.pixels()) v = v ? static_cast<uint16_t>(v + 8) : 0;  // 8 mm farther
  const TrackingState sc = run_frame(cpu, moved, true, false);
  const TrackingState sg = run_frame(gpu, moved, true, false);
  EXPECT_EQ(sc.tracked, 1);
  EXPECT_EQ(sg.tracked, 1);
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(sc.T_world_cam.m[r][3], sg.T_world_cam.m[r][3], kTrackedPoseTol_m) << r;
  }
}

TEST(BackendParity, RendersAgree) {
  KFX_REQUIRE_CUDA();
  const HostImage<uint16_t> depth = scene_depth();
  const BackendPair pair = backends_after_fusing(depth);
  Backend &cpu = *pair.cpu, &gpu = *pair.gpu;
  run_frame(cpu, depth, true, false, true);
  run_frame(gpu, depth, true, false, true);
  const Renders c = cpu.read_renders(), g = gpu.read_renders();
  auto differ = [](Rgba8 a, Rgba8 b, int tol) {
    return std::abs(a.r - b.r) > tol || std::abs(a.g - b.g) > tol || std::abs(a.b - b.b) > tol ||
           a.a != b.a;
  };
  int depth_mismatch = 0, track_mismatch = 0, volume_mismatch = 0, lit = 0, inliers = 0;
  for (int i = 0; i < 320 * 240; ++i) {
    depth_mismatch += differ(c.depth.pixels()[i], g.depth.pixels()[i], 0);  // same depth in
    track_mismatch += differ(c.track.pixels()[i], g.track.pixels()[i], 0);
    inliers += c.track.pixels()[i].r == 128 && c.track.pixels()[i].b == 128;
    // Shading from normals that agree within the raycast's tolerance: a few levels of 255.
    volume_mismatch += differ(c.volume.pixels()[i], g.volume.pixels()[i], 3);
    lit += c.volume.pixels()[i].r > 0;
  }
  EXPECT_GT(inliers, 320 * 240 / 2);
  EXPECT_GT(lit, 320 * 240 / 2);
  EXPECT_EQ(depth_mismatch, 0);
  EXPECT_LE(track_mismatch, kMaxPixelMismatchFraction * 320 * 240);
  EXPECT_LE(volume_mismatch, kMaxPixelMismatchFraction * 320 * 240);
}

/// Settings for a synthetic `input`: its reader's recommended ones, integration every frame and
/// the compute size equal to the input size.
PipelineConfig synthetic_config(const std::string& input) {
  PipelineConfig config;
  set_config_value(config, "integration_rate", "1");
  set_config_value(config, "compute_size_ratio", "1");
  for (const auto& [key, value] : io::open_reader(input)->recommended_settings())
    set_config_value(config, key, value);
  return config;
}

TEST(BackendParity, SyntheticTrajectoriesAgree) {
  KFX_REQUIRE_CUDA();
  const std::string input = "synthetic:frames=60,width=320,height=240";
  test::expect_backends_agree(input, synthetic_config(input), 60);
}

/// Two runs that must agree bit for bit: same frames tracked, identical poses.
void expect_identical_runs(const test::SequenceRun& a, const test::SequenceRun& b) {
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  EXPECT_EQ(a.tracked, b.tracked);
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    for (int k = 0; k < 3; ++k) ASSERT_EQ(a.trajectory[i].t[k], b.trajectory[i].t[k]) << i;
    for (int k = 0; k < 4; ++k) ASSERT_EQ(a.trajectory[i].q[k], b.trajectory[i].q[k]) << i;
  }
}

// The photometric tracking term (photometric_weight) runs the same kernel bodies on both
// backends: intensity pyramids, the kept reference and the rows beside the ICP's.
TEST(BackendParity, PhotometricTrajectoriesAgree) {
  KFX_REQUIRE_CUDA();
  const std::string input = "synthetic:frames=60,width=320,height=240,speed=2";
  PipelineConfig config = synthetic_config(input);
  set_config_value(config, "photometric_weight", "0.001");
  const auto cpu = test::expect_backends_agree(input, config, 60, "photometric_weight=0.001");
  EXPECT_GT(cpu.tracked, 50);
}

void expect_repeatable(BackendKind kind) {
  const std::string input = "synthetic:frames=25,width=320,height=240";
  const PipelineConfig config = synthetic_config(input);
  const auto a = test::run_sequence(input, config, kind);
  const auto b = test::run_sequence(input, config, kind);
  EXPECT_GT(a.tracked, 15);
  expect_identical_runs(a, b);
}

TEST(BackendParity, CpuRepeatsBitForBit) { expect_repeatable(BackendKind::kCpu); }

TEST(BackendParity, CudaRepeatsBitForBit) {
  KFX_REQUIRE_CUDA();
  expect_repeatable(BackendKind::kCuda);
}

/// Runs `input` with the on|off setting `key` off, then on, on `kind`: at least `min_tracked`
/// frames tracked, and the two runs the same bits.
void expect_setting_changes_no_bit(const std::string& key, const std::string& input,
                                   PipelineConfig config, BackendKind kind, int min_tracked) {
  set_config_value(config, key, "off");
  const auto off = test::run_sequence(input, config, kind);
  set_config_value(config, key, "on");
  const auto on = test::run_sequence(input, config, kind);
  EXPECT_GT(off.tracked, min_tracked);
  expect_identical_runs(off, on);
}

// cuda_icp_persistent runs a level's iterations in one cooperative launch; it must not change a
// bit (same per-block sums, same final order, same solve).
TEST(BackendParity, PersistentIcpIsBitIdenticalToOneLaunchPerIteration) {
  KFX_REQUIRE_CUDA();
  const std::string input = "synthetic:frames=25,width=320,height=240";
  PipelineConfig config = synthetic_config(input);
  expect_setting_changes_no_bit("cuda_icp_persistent", input, config, BackendKind::kCuda, 15);
}

// At 640×480 with one reduction block per 256 pixels (1,200 blocks: more than fit at once on any
// current GPU, at most 2,048 threads, i.e. 8 such blocks, per SM and at most 148 SMs), each block
// of the persistent launch runs several reduction blocks in turn: still the same bits.
TEST(BackendParity, PersistentIcpWithMoreReductionBlocksThanResidentIsBitIdentical) {
  KFX_REQUIRE_CUDA();
  const std::string input = "synthetic:frames=8,width=640,height=480";
  PipelineConfig config = synthetic_config(input);
  set_config_value(config, "cuda_reduce_blocks", "65535");
  expect_setting_changes_no_bit("cuda_icp_persistent", input, config, BackendKind::kCuda, 2);
}

// With many pipelines on one GPU the persistent launch takes fewer blocks (22 of an H200's 132
// for 32 pipelines), each running more reduction blocks in turn: still the same bits, at 320×240
// and at 640×480 with 1,200 reduction blocks.
TEST(BackendParity, PersistentIcpOnAShareOfTheGpuIsBitIdentical) {
  KFX_REQUIRE_CUDA();
  for (const char* input :
       {"synthetic:frames=25,width=320,height=240", "synthetic:frames=8,width=640,height=480"}) {
    PipelineConfig config = synthetic_config(input);
    set_config_value(config, "cuda_icp_persistent", "on");
    if (std::string(input).find("640") != std::string::npos) {
      set_config_value(config, "cuda_reduce_blocks", "65535");
    }
    const auto alone = test::run_sequence(input, config, BackendKind::kCuda, 0, 1);
    const auto shared = test::run_sequence(input, config, BackendKind::kCuda, 0, 32);
    EXPECT_GT(alone.tracked, 2) << input;
    expect_identical_runs(alone, shared);
  }
}

// cuda_z_chunks splits each integration column into z-ranges, one thread each; every voxel is
// still updated once, by the same arithmetic: the same bits for any split (0 = the default).
TEST(BackendParity, IntegrationZChunksChangeNoBit) {
  KFX_REQUIRE_CUDA();
  const std::string input = "synthetic:frames=20,width=320,height=240";
  PipelineConfig config = synthetic_config(input);
  const auto by_default = test::run_sequence(input, config, BackendKind::kCuda);
  EXPECT_GT(by_default.tracked, 10);
  for (const char* chunks : {"1", "7", "64"}) {
    set_config_value(config, "cuda_z_chunks", chunks);
    expect_identical_runs(by_default, test::run_sequence(input, config, BackendKind::kCuda));
  }
}

TEST(BackendParity, PersistentIcpTrajectoryAgreesWithCpu) {
  KFX_REQUIRE_CUDA();
  const std::string input = "synthetic:frames=60,width=320,height=240";
  PipelineConfig config = synthetic_config(input);
  set_config_value(config, "cuda_icp_persistent", "on");
  test::expect_backends_agree(input, config, 60);
}

// The CPU backend ignores the CUDA settings: the same bits with cuda_icp_persistent on.
TEST(BackendParity, CpuIgnoresPersistentIcp) {
  const std::string input = "synthetic:frames=8,width=160,height=120";
  PipelineConfig config = synthetic_config(input);
  set_config_value(config, "volume_resolution", "128");  // fast enough for CI
  expect_setting_changes_no_bit("cuda_icp_persistent", input, config, BackendKind::kCpu, 2);
}

TEST(BackendSelection, CudaRequestWithoutGpuIsAClearError) {
  std::string why_not;
  if (cuda_available(&why_not)) GTEST_SKIP() << "a CUDA device is present";
  try {
    make_backend(BackendKind::kCuda, small_setup());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("CUDA backend was requested"), std::string::npos);
  }
  EXPECT_EQ(make_backend(BackendKind::kAuto, small_setup())->name(), "cpu");
}

/// Bilateral settings of `mode` as make_stage_params derives them (sigma 4 px, 0.1 m).
BilateralParams bilateral(BilateralMode mode, int radius_px, bool zero_padded, float max_depth_m) {
  BilateralParams p = make_bilateral_params(mode, radius_px, 4.0f, 0.1f, zero_padded);
  p.max_depth_m = max_depth_m;
  return p;
}

/// Pixels whose bits differ (all three components for vectors).
template <class T>
int differing_pixels(const HostImage<T>& a, const HostImage<T>& b) {
  int n = 0;
  for (size_t i = 0; i < a.pixels().size(); ++i) {
    n += std::memcmp(&a.pixels()[i], &b.pixels()[i], sizeof(T)) != 0;
  }
  return n;
}

/// The CUDA backend with cuda_fused_preprocess off and on, fed the same frames (far, shifted,
/// nearer: the largest depth goes down as well as up) with preprocess settings `pre`: after every
/// frame, the unfiltered and filtered depth, every pyramid level and the state the same bits,
/// and the largest depth the one of the frame (the fused path resets it without a memset).
void expect_fused_preprocess_changes_no_bit(BackendSetup setup, const BilateralParams& pre) {
  setup.cuda.fused_preprocess = false;
  const auto off = make_backend(BackendKind::kCuda, setup);
  setup.cuda.fused_preprocess = true;
  const auto on = make_backend(BackendKind::kCuda, setup);
  const Mat4f start = Mat4f::translation(Vec3f{2.0f, 2.0f, 0.0f});
  off->reset(start);
  on->reset(start);
  const HostImage<uint16_t> far = scene_depth();
  HostImage<uint16_t> shifted = far, nearer = far;
  for (auto& v : shifted.pixels()) v = v ? static_cast<uint16_t>(v + 8) : 0;
  for (auto& v : nearer.pixels()) v = static_cast<uint16_t>(v * 4 / 5);
  const HostImage<uint16_t>* frames[] = {&far, &far, &shifted, &nearer, &far, &shifted};
  int f = 0;
  for (const HostImage<uint16_t>* depth : frames) {
    const bool track = f > 0;
    const TrackingState a = run_frame(*off, *depth, track, !track, false, pre);
    const TrackingState b = run_frame(*on, *depth, track, !track, false, pre);
    const std::string at = "frame " + std::to_string(f++);
    EXPECT_EQ(std::memcmp(&a, &b, sizeof a), 0) << at;  // pose, largest depth, decisions
    const MmToMArgs mm{depth->view(), {}, setup.compute_ratio, pre.max_depth_m};
    float max_depth_m = 0.0f;
    for (int y = 0; y < setup.compute_height_px(); ++y) {
      for (int x = 0; x < setup.compute_width_px(); ++x) {
        max_depth_m = std::max(max_depth_m, mm_to_m_value(x, y, mm));
      }
    }
    EXPECT_EQ(b.max_depth_m, max_depth_m) << at;
    const DebugMaps ma = off->read_maps(), mb = on->read_maps();
    EXPECT_EQ(differing_pixels(ma.depth_m, mb.depth_m), 0) << at;
    EXPECT_EQ(differing_pixels(ma.filtered_m, mb.filtered_m), 0) << at;
    if (!track) continue;
    ASSERT_EQ(ma.level_depth_m.size(), static_cast<size_t>(setup.pyramid_levels));
    ASSERT_EQ(mb.level_depth_m.size(), static_cast<size_t>(setup.pyramid_levels));
    for (int l = 0; l < setup.pyramid_levels; ++l) {
      EXPECT_EQ(differing_pixels(ma.level_depth_m[l], mb.level_depth_m[l]), 0) << at << l;
      EXPECT_EQ(differing_pixels(ma.level_vertex[l], mb.level_vertex[l]), 0) << at << l;
      EXPECT_EQ(differing_pixels(ma.level_normal[l], mb.level_normal[l]), 0) << at << l;
    }
  }
}

// cuda_fused_preprocess runs mm → m with the bilateral filter in one launch and the whole
// pyramid in one more; every output must keep its bits, for every preprocess setting.
TEST(BackendParity, FusedPreprocessIsBitIdenticalPerFrame) {
  KFX_REQUIRE_CUDA();
  expect_fused_preprocess_changes_no_bit(small_setup(), exact_bilateral());
  expect_fused_preprocess_changes_no_bit(small_setup(),
                                         bilateral(BilateralMode::kExact, 4, true, 2.2f));
  expect_fused_preprocess_changes_no_bit(small_setup(),
                                         bilateral(BilateralMode::kSpatial3x3, 2, true, 0.0f));
  // Compute ratio 2 (160×120, partial tiles) and four levels down to 20×15.
  BackendSetup half = small_setup();
  half.compute_ratio = 2;
  half.pyramid_levels = 4;
  expect_fused_preprocess_changes_no_bit(half,
                                         bilateral(BilateralMode::kSpatial3x3, 2, false, 2.5f));
  expect_fused_preprocess_changes_no_bit(half, bilateral(BilateralMode::kExact, 3, false, 0.0f));
}

TEST(BackendParity, FusedPreprocessIsBitIdenticalOverASequence) {
  KFX_REQUIRE_CUDA();
  const std::string input = "synthetic:frames=25,width=320,height=240";
  PipelineConfig config = synthetic_config(input);
  expect_setting_changes_no_bit("cuda_fused_preprocess", input, config, BackendKind::kCuda, 15);
  // A depth cut-off (the synthetic room reaches beyond 3 m).
  PipelineConfig cut = config;
  set_config_value(cut, "max_depth_m", "3");
  expect_setting_changes_no_bit("cuda_fused_preprocess", input, cut, BackendKind::kCuda, 10);
  // The thesis's approximate filter, zero padding and four pyramid levels. (With the cut-off as
  // well it loses track: the spatial-only filter averages the cut pixels' zeros in.)
  set_config_value(config, "bilateral_mode", "spatial3x3");
  set_config_value(config, "zero_padded_depth", "on");
  set_config_value(config, "pyramid_iterations", "4,3,2,2");
  expect_setting_changes_no_bit("cuda_fused_preprocess", input, config, BackendKind::kCuda, 15);
}

TEST(BackendParity, FusedPreprocessAtComputeRatioTwoIsBitIdentical) {
  KFX_REQUIRE_CUDA();
  const std::string input = "synthetic:frames=12,width=640,height=480";
  PipelineConfig config = synthetic_config(input);
  set_config_value(config, "compute_size_ratio", "2");
  expect_setting_changes_no_bit("cuda_fused_preprocess", input, config, BackendKind::kCuda, 5);
}

}  // namespace
}  // namespace kfx
