#pragma once
/// Per-run statistics over frames: counts, per-stage mean and median times, frames/s.

#include <array>
#include <nlohmann/json.hpp>
#include <optional>
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
  TrackingTimeline tracking_states;  ///< each frame's tracking state (good / poor / lost)
  /// Relocalisation (setting relocalise): attempt frames, the frames the camera was found at,
  /// and the relocaliser's figures after the run (set by the caller; none when off).
  int relocalisation_attempt_frames = 0;
  std::vector<double> attempt_computation_ms;  ///< each attempt frame's computation time
  std::vector<int> relocalised_frames;
  std::optional<RelocaliserFigures> relocaliser;
  double ate_rmse_m = -1.0;  ///< set when ground truth was evaluated
  std::array<std::vector<double>, static_cast<int>(Stage::kCount)> stage_ms;
  std::vector<double> computation_ms;
  // The block map (volume=blocks): its size after the last frame, and what did not fit.
  int map_blocks = 0;
  unsigned long long map_bytes = 0;  ///< bytes those blocks take (colour included)
  long long map_blocks_dropped = 0;  ///< blocks frames needed that the budget had no room for
  int map_frames_short = 0;          ///< frames with blocks dropped
  int map_first_short_frame = -1;    ///< the first of them, −1 if none
  int map_blocks_swapped = 0;        ///< blocks swapped out to host memory (map_swap)
  unsigned long long map_swapped_bytes = 0;  ///< bytes they take
  int map_swap_passes = 0;                   ///< swap passes run
  double map_swap_s = 0;                     ///< their wall time, seconds
  /// The tracking constraint (FrameReport::constraint's smallest eigenvalue) of every tracked
  /// frame, and the frame with the lowest.
  std::vector<double> tracking_constraint;
  double tracking_constraint_min = -1;
  int tracking_constraint_min_frame = -1;

  /// Adds one frame.
  void add(const FrameReport& report);
  /// 1 / mean computation time (preprocess + track + integrate + raycast).
  double frames_per_second() const;
  /// {"frames", "tracked", "lost", "lost_frames", "integrated", "frames_per_second", "stages_ms":
  /// {name: {mean, median}}, "computation_ms": {mean, median}}; with a block map also
  /// "map_blocks", "map_bytes" (blocks × block_bytes(colour)), "map_blocks_dropped",
  /// "map_frames_short_of_blocks", "map_first_frame_short_of_blocks", "map_blocks_swapped",
  /// "map_swapped_bytes", "map_swap_passes", "map_swap_seconds"; when a frame was tracked,
  /// "tracking_constraint": {"min", "min_frame", "median"}; "tracking_states"
  /// (output::add_tracking_states).
  nlohmann::json to_json() const;
  /// "500 frames, 496 tracked, 20.1 frames/s, ATE 0.84 cm".
  std::string one_line() const;
};

/// Median of a list (0 for an empty list).
double median_of(std::vector<double> values);
/// Mean of a list (0 for an empty list).
double mean_of(const std::vector<double>& values);

}  // namespace kfx::cli
