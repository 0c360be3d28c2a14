#pragma once
/// The tracking state of every frame, judged from the ICP's own evidence: good, poor or lost.
/// One floor above the frame loop (DESIGN.md, "A map object, and a floor above the frame
/// loop"): it reads each finished frame's figures and changes nothing the frame computed, so
/// `exact` keeps SLAMBench's trajectory bit for bit while reporting the state.

#include <vector>

#include "kfx/tracking_quality.hpp"

namespace kfx {

/// What the judge reads of one finished frame.
struct TrackingEvidence {
  bool tracking_ran = false;  ///< tracking was attempted
  bool tracked = false;       ///< the accept test passed
  /// The tracking constraint's smallest eigenvalue (kernels/tracking_constraint.hpp: m² of
  /// mean squared residual per unit step along the weakest direction, per inlier).
  float constraint_min = 0;
};

/// Judges each frame in order: lost when the accept test failed; poor when the view has left
/// one direction nearly free for a stretch of tracked frames (the pose can slide along it while
/// every frame passes the accept test); good otherwise. A frame that ran no tracking (the
/// bootstrap frames, frames off the tracking rate) keeps the state of the frame before it.
///
/// The bounds were measured (bench/RESULTS.md, "Tracking state"): on the synthetic house's C
/// door, where the pose slid 0.5 m, the constraint fell below kWeakConstraint at frame 3054 and
/// stayed there for 120 frames; on TUM fr1_xyz single frames dip below it, never 10 in a row.
/// The inlier fraction and the residual did not tell the slide from views that track well
/// (the door's 0.35 and 3 mm lie inside the TUM sequences' range), so they are not used.
class TrackingJudge {
 public:
  /// A tracked frame is weak when its tracking constraint is below this.
  static constexpr float kWeakConstraint = 0.005f;
  /// Weak frames in a row before the state turns poor: single weak frames, and short runs of
  /// them, are common on views that track well (a desk seen at an angle); a slide needs a run.
  static constexpr int kWeakFramesToPoor = 10;
  /// Tracked frames in a row at or above kWeakConstraint before a poor state turns good again.
  static constexpr int kStrongFramesToGood = 3;

  /// `starts_lost`: the first frames are lost until one is tracked (a loaded map that has not
  /// located the camera yet); else good (the first pose is given).
  explicit TrackingJudge(bool starts_lost = false) { restart(starts_lost); }
  /// Starts over, as the constructor.
  void restart(bool starts_lost);
  /// The state of the next frame.
  TrackingQuality judge(const TrackingEvidence& evidence);
  /// The state of the last judged frame (the starting state before any).
  TrackingQuality current() const { return state_; }

 private:
  TrackingQuality state_ = TrackingQuality::kGood;
  int weak_run_ = 0;    ///< tracked frames in a row below kWeakConstraint
  int strong_run_ = 0;  ///< tracked frames in a row at or above it
};

/// Counts of each state over a run and its stretches of poor and lost frames, for stats.json.
struct TrackingStretch {
  TrackingQuality quality = TrackingQuality::kPoor;
  int first_frame = 0;  ///< frame numbers as the input numbers them
  int last_frame = 0;
  int frames = 0;  ///< frames in it (fewer than last − first + 1 where frames were skipped)
};

/// Accumulates the states of a run's frames in order.
class TrackingTimeline {
 public:
  /// Adds frame `frame` (the input's number) in state `quality`.
  void add(int frame, TrackingQuality quality);
  /// Frames in each state.
  int count(TrackingQuality quality) const { return counts_[static_cast<int>(quality)]; }
  /// The stretches of poor and of lost frames, in order.
  const std::vector<TrackingStretch>& stretches() const { return stretches_; }

 private:
  int counts_[3] = {0, 0, 0};
  std::vector<TrackingStretch> stretches_;
  bool open_ = false;  ///< the last stretch is still growing
};

}  // namespace kfx
