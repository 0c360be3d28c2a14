#pragma once
/// Per-run statistics over frames: counts, per-stage mean and median times, frames/s.

#include <array>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pipeline/pipeline.hpp"

namespace kfx::cli {

/// Accumulates frame reports into run statistics.
struct RunSummary {
  int frames = 0;
  int tracked = 0;
  int lost = 0;  ///< frames where tracking ran and failed (pose kept, not integrated)
  std::vector<int> lost_frames;  ///< their frame numbers, in order (the report marks them)
  int integrated = 0;
  double ate_rmse_m = -1.0;  ///< set when ground truth was evaluated
  std::array<std::vector<double>, static_cast<int>(Stage::kCount)> stage_ms;
  std::vector<double> computation_ms;

  /// Adds one frame.
  void add(const FrameReport& report);
  /// 1 / mean computation time (preprocess + track + integrate + raycast).
  double frames_per_second() const;
  /// {"frames", "tracked", "lost", "lost_frames", "integrated", "frames_per_second", "stages_ms":
  /// {name: {mean, median}}, "computation_ms": {mean, median}}.
  nlohmann::json to_json() const;
  /// "500 frames, 496 tracked, 20.1 frames/s, ATE 0.84 cm".
  std::string one_line() const;
};

/// Median of a list (0 for an empty list).
double median_of(std::vector<double> values);
/// Mean of a list (0 for an empty list).
double mean_of(const std::vector<double>& values);

}  // namespace kfx::cli
