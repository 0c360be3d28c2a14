#pragma once
/// Test helper: runs the pipeline over a whole input and returns its trajectory, plus the
/// per-frame position comparison used by the parity tests, and the CPU-against-GPU check.

#include <string>
#include <utility>
#include <vector>

#include "io/reader.hpp"
#include "io/trajectory.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx::test {

/// Path of a folder or file under ../shared (KFX_SHARED_DIR), and whether it exists.
std::string shared_path(const std::string& relative);
bool shared_exists(const std::string& relative);

/// The configuration a test run of `reader`'s input starts from: the exact preset with the
/// reader's recommended settings, computed at the input's size (compute_size_ratio 1) and with
/// every frame integrated (integration_rate 1).
PipelineConfig input_config(const io::Reader& reader);

/// A finished run.
struct SequenceRun {
  std::vector<io::StampedPose> trajectory;  ///< pose after each frame
  std::vector<io::StampedPose> ground_truth;
  int frames = 0;
  int tracked = 0;
};

/// Runs `input` through a pipeline with `config` on `backend`; intrinsics from the config's
/// camera when set, else the reader's default. `max_frames` 0 = all. `pipelines_on_device`: as
/// if that many pipelines shared the GPU (BackendSetup; speed only).
SequenceRun run_sequence(const std::string& input, const PipelineConfig& config,
                         BackendKind backend = BackendKind::kCpu, int max_frames = 0,
                         int pipelines_on_device = 1);

/// Per-frame camera position differences (metres) of two trajectories paired by equal stamps.
struct PositionDifference {
  int pairs = 0;
  double median_m = 0, p95_m = 0, max_m = 0;
};
PositionDifference compare_positions(const std::vector<io::StampedPose>& a,
                                     const std::vector<io::StampedPose>& b);

/// Median and largest per-frame distance (metres) of positions taken relative to each run's
/// first frame, frames paired by index (runs of one input from the same first frame).
std::pair<double, double> relative_position_difference(const std::vector<io::StampedPose>& a,
                                                       const std::vector<io::StampedPose>& b);

/// The CPU and the GPU may differ in float summation order only: per-frame positions within a
/// median of 1 mm and a 95th percentile of 1 cm (the issues' trajectory bounds).
constexpr double kBackendMedianTol_m = 1e-3;
constexpr double kBackendP95Tol_m = 1e-2;

/// Runs `input` with `config` on the CPU and on the GPU and expects (gtest EXPECTs, `label` in
/// every message) the same tracked frames, a pose for each of the input's `frames` frames, and
/// positions within kBackendMedianTol_m / kBackendP95Tol_m. The caller skips without a GPU.
/// Returns the CPU run, for checks of its own.
SequenceRun expect_backends_agree(const std::string& input, const PipelineConfig& config,
                                  int frames, const std::string& label = "");

}  // namespace kfx::test
