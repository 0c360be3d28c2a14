#pragma once
/// Divergence: how many frames of an aligned trajectory lie farther than a fixed distance from
/// the ground truth, and the first of them. "Tracked" counts only frames whose ICP converged, so
/// a run whose map has drifted away can still call most frames tracked; this measure catches it.

#include <cstddef>
#include <vector>

#include "eval/associate.hpp"
#include "eval/ate.hpp"
#include "io/trajectory.hpp"

namespace kfx::eval {

/// The default bound: a frame whose aligned position error exceeds 10 cm has left the ground
/// truth. Chosen an order of magnitude above the ATE RMSE of a healthy run on our sequences
/// (0.5–2.5 cm) and of the transient spread between SLAMBench's own builds (3–5 cm at most,
/// ../shared/reference/README.md), and well below the metre-scale errors of a lost map.
constexpr double kDivergenceBoundM = 0.10;

/// Frames whose aligned position error exceeds a bound.
struct DivergenceResult {
  double bound_m = kDivergenceBoundM;  ///< the bound, metres (strictly greater counts)
  std::size_t frames_over = 0;         ///< paired frames with error > bound_m
  std::size_t frames_evaluated = 0;    ///< paired frames looked at
  bool any_over = false;               ///< whether any frame exceeds the bound
  std::size_t first_over_index = 0;    ///< estimate index of the first such frame (any_over)
  double first_over_stamp_s = 0.0;     ///< its stamp (any_over)
  /// The departure: the first frame whose error exceeds the bound when the estimate is aligned
  /// on the frames up to and including it only (a causal alignment, so drift that comes later
  /// cannot move it earlier, as it can move first_over_index).
  bool departed = false;
  std::size_t departure_index = 0;  ///< estimate index of the departure (departed)
  double departure_stamp_s = 0.0;   ///< its stamp (departed)
};

/// Divergence of associated trajectories whose TUM-style ATE is `ate` (compute_ate() with the
/// same association and `flip_y`): counts the pairs (in estimate-stamp order, as compute_ate()
/// keeps them) whose `ate.errors_m` exceeds `bound_m` and names the first by its index into
/// `est` (the frame number for kfx runs, one pose per frame) and its stamp. Those errors are
/// after the rigid alignment of the whole trajectory, which for a trajectory that leaves the
/// ground truth spreads the drift over every frame (with a drift of metres even frame 0 can be
/// over the bound); the departure frame, from prefix alignments, says when it left. Throws
/// kfx::Error when the sizes disagree or `bound_m` is not a positive finite number.
DivergenceResult compute_divergence(const std::vector<io::StampedPose>& est,
                                    const std::vector<io::StampedPose>& gt,
                                    const Association& association, const AteResult& ate,
                                    bool flip_y, double bound_m = kDivergenceBoundM);

}  // namespace kfx::eval
