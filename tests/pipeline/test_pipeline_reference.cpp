/// Parity with SLAMBench KFusion on real data (../shared/data and ../shared/reference): the
/// exact preset on the CPU backend must give the same trajectory as SLAMBench's own builds.

#include <gtest/gtest.h>

#include "eval/report.hpp"
#include "support/sequence_runner.hpp"

namespace kfx::test {
namespace {

// "Same trajectory" as the issue defines it: what SLAMBench's builds achieve against each
// other (their CUDA/OpenCL/OpenMP builds differ by a median of 0.03–0.3 mm, a 95th percentile
// of 2–5 mm): median ≤ 1 mm, 95th percentile ≤ 1 cm.
constexpr double kMaxMedianDifference_m = 0.001;
constexpr double kMaxP95Difference_m = 0.01;
// ATE RMSE within 10 % of the reference's.
constexpr double kAteRelativeTolerance = 0.10;

PipelineConfig icl_office_config() {
  PipelineConfig c;                                    // exact preset
  set_config_value(c, "camera", "481.2,480,320,240");  // SLAMBench's ICL intrinsics
  set_config_value(c, "volume_size_m", "5");
  set_config_value(c, "init_pose_factor", "0.5,0.5,0");
  set_config_value(c, "integration_rate", "1");
  return c;
}

PipelineConfig tum_xyz_config() {
  PipelineConfig c;
  set_config_value(c, "camera", "517.3,516.5,318.6,255.3");
  set_config_value(c, "volume_size_m", "4");
  set_config_value(c, "init_pose_factor", "0.5,0.5,0");
  set_config_value(c, "integration_rate", "1");
  return c;
}

/// SLAMBench's trajectory of `dataset` (../shared/reference), its first `frames` poses
/// (0 = all).
std::vector<io::StampedPose> reference_trajectory(const std::string& dataset, int frames = 0) {
  auto ref =
      io::read_tum_trajectory(shared_path("reference/" + dataset + ".openmp-2threads.tum.txt"));
  if (frames > 0 && static_cast<int>(ref.size()) > frames) ref.resize(frames);
  return ref;
}

/// Runs `dataset`'s first `frames` frames (0 = all) and expects SLAMBench's positions, and an
/// ATE within kAteRelativeTolerance of the ATE SLAMBench's own trajectory has over the same
/// frames (positions only: SLAMBench logs no orientation).
void expect_reference_parity(const std::string& dataset, const PipelineConfig& config, bool flip_y,
                             int frames = 0) {
  const std::string data = "data/" + dataset;
  const std::string reference = "reference/" + dataset + ".openmp-2threads.tum.txt";
  if (!shared_exists(data) || !shared_exists(reference)) {
    GTEST_SKIP() << "needs ../shared/" << data << " and ../shared/" << reference;
  }
  const SequenceRun run = run_sequence(shared_path(data), config, BackendKind::kCpu, frames);
  const auto ref = reference_trajectory(dataset, frames);
  const PositionDifference diff = compare_positions(run.trajectory, ref);
  EXPECT_GE(diff.pairs, static_cast<int>(ref.size()) - 1);
  EXPECT_LE(diff.median_m, kMaxMedianDifference_m);
  EXPECT_LE(diff.p95_m, kMaxP95Difference_m);
  eval::EvalOptions options;
  options.flip_y = flip_y;
  const auto ate = eval::evaluate_trajectories(run.trajectory, run.ground_truth, options);
  const double reference_ate_m =
      eval::evaluate_trajectories(ref, run.ground_truth, options).ate.stats_m.rmse;
  EXPECT_NEAR(ate.ate.stats_m.rmse, reference_ate_m, kAteRelativeTolerance * reference_ate_m);
  ::testing::Test::RecordProperty("median_difference_mm", std::to_string(diff.median_m * 1000));
  ::testing::Test::RecordProperty("p95_difference_mm", std::to_string(diff.p95_m * 1000));
  ::testing::Test::RecordProperty("ate_rmse_cm", std::to_string(ate.ate.stats_m.rmse * 100));
  std::cout << dataset << ": " << run.tracked << "/" << run.frames << " tracked, position "
            << "difference to SLAMBench median " << diff.median_m * 1000 << " mm, p95 "
            << diff.p95_m * 1000 << " mm, max " << diff.max_m * 1000 << " mm; ATE RMSE "
            << ate.ate.stats_m.rmse * 100 << " cm (SLAMBench's over the same frames "
            << reference_ate_m * 100 << " cm)\n";
}

// The office's whole 500 frames against SLAMBench (y flipped to evaluate: SLAMBench's ICL
// intrinsics mirror y).
TEST(PipelineReference, IclOfficeKt0MatchesSlambench) {
  expect_reference_parity("icl_office_kt0", icl_office_config(), true);
}

// fr1_xyz's first 400 of its 798 frames: half the sequence's sweep of the desk, long enough to
// fill and saturate the model (weights reach max_weight after 100 integrations) and to track
// against it; the office above runs its whole sequence.
TEST(PipelineReference, TumFr1XyzMatchesSlambench) {
  expect_reference_parity("tum_fr1_xyz", tum_xyz_config(), false, 400);
}

// The intrinsics conventions below show from the first frames on: the office's first 150.
constexpr int kConventionFrames = 150;

TEST(PipelineReference, IclOfficeKt0NegativeFyIsSlambenchsRunMirrored) {
  // fy = −480 (image y up, as ICL-NUIM's camera) with SLAMBench's principal point: the same
  // computation as SLAMBench's +480 run in a world mirrored in y, so the trajectory is the
  // reference's mirrored about the first camera, and it evaluates without any y flip to the
  // ATE that SLAMBench's run has with the flip.
  if (!shared_exists("data/icl_office_kt0")) GTEST_SKIP() << "needs ../shared/data";
  PipelineConfig c = icl_office_config();
  set_config_value(c, "camera", "481.2,-480,320,240");
  const SequenceRun run =
      run_sequence(shared_path("data/icl_office_kt0"), c, BackendKind::kCpu, kConventionFrames);
  const auto reference = reference_trajectory("icl_office_kt0", kConventionFrames);
  auto mirrored = reference;
  const double y0 = 0.5 * 5.0;  // first camera y in the volume frame
  for (auto& p : mirrored) p.t[1] = 2 * y0 - p.t[1];
  const PositionDifference diff = compare_positions(run.trajectory, mirrored);
  EXPECT_GE(diff.pairs, kConventionFrames - 1);
  EXPECT_LE(diff.median_m, kMaxMedianDifference_m);
  EXPECT_LE(diff.p95_m, kMaxP95Difference_m);
  const auto ate = eval::evaluate_trajectories(run.trajectory, run.ground_truth, {});
  eval::EvalOptions flipped;
  flipped.flip_y = true;
  const double reference_ate_m =
      eval::evaluate_trajectories(reference, run.ground_truth, flipped).ate.stats_m.rmse;
  EXPECT_NEAR(ate.ate.stats_m.rmse, reference_ate_m, kAteRelativeTolerance * reference_ate_m);
  std::cout << "icl_office_kt0, fy = -480: ATE RMSE " << ate.ate.stats_m.rmse * 100
            << " cm without flip (SLAMBench's with flip " << reference_ate_m * 100
            << " cm); vs mirrored SLAMBench median " << diff.median_m * 1000 << " mm, p95 "
            << diff.p95_m * 1000 << " mm\n";
}

TEST(PipelineReference, IclOfficeKt0TrueIntrinsicsNeedNoFlip) {
  // ICL-NUIM's true camera (fy = −480, cx, cy = 319.5, 239.5): the world is not mirrored, so
  // the trajectory evaluates against the ground truth without a y flip, and a flip would be
  // wrong. Measured here: 0.13 cm over the first 150 frames without the flip, 2.6 cm with it,
  // hence the 0.5 cm bound. (Over all 500 frames the half-pixel principal point costs ATE:
  // 1.4–1.6 cm with either sign of fy, against 0.86 cm with 320, 240.)
  if (!shared_exists("data/icl_office_kt0")) GTEST_SKIP() << "needs ../shared/data";
  PipelineConfig c = icl_office_config();
  set_config_value(c, "camera", "481.2,-480,319.5,239.5");
  const SequenceRun run =
      run_sequence(shared_path("data/icl_office_kt0"), c, BackendKind::kCpu, kConventionFrames);
  EXPECT_EQ(run.frames, kConventionFrames);
  EXPECT_GE(run.tracked, run.frames - 10);
  const auto ate = eval::evaluate_trajectories(run.trajectory, run.ground_truth, {});
  EXPECT_LT(ate.ate.stats_m.rmse, 0.005);
  eval::EvalOptions flipped;
  flipped.flip_y = true;
  const auto ate_flipped = eval::evaluate_trajectories(run.trajectory, run.ground_truth, flipped);
  EXPECT_GT(ate_flipped.ate.stats_m.rmse, 3 * ate.ate.stats_m.rmse);  // flipping would be wrong
  std::cout << "icl_office_kt0, true intrinsics: " << run.tracked << "/" << run.frames
            << " tracked, ATE RMSE " << ate.ate.stats_m.rmse * 100 << " cm without flip, "
            << ate_flipped.ate.stats_m.rmse * 100 << " cm with\n";
}

}  // namespace
}  // namespace kfx::test
