#pragma once
/// Which pose, if any, to take for a view located alone (Pipeline::localise): one depth image,
/// no previous pose, no later frames to verify with. Each of the view's nearest keyframes was
/// tried (the map raycast from its pose, the image tracked against that, the accept test), and
/// a pose that passed was tried once more from where it ended (a fresh raycast there). The
/// stream's relocaliser trusts a pose after several frames agree; one image has only its own
/// evidence, so the rule is stricter: the pose must pass twice and barely move the second
/// time, and every candidate that passed must agree on it (two that pass far apart are
/// ambiguous views, and none is taken).

#include <vector>

#include "core/math.hpp"

namespace kfx {

/// One keyframe tried for a view located alone.
struct LocaliseAttempt {
  int keyframe = -1;  ///< its index in the keyframe database
  /// Which of perturbed_poses() of the keyframe's pose the attempt started from; −1: the
  /// keyframe's pose itself.
  int perturbation = -1;
  float dissimilarity = 1.0f;  ///< share of ferns whose codes differ from the view's
  bool accepted = false;       ///< passed the accept test from the keyframe's pose
  bool confirmed = false;      ///< ... and again from the pose it reached
  Mat4f T_world_cam =
      Mat4f::identity();       ///< the pose reached (after the second pass when accepted)
  float confirm_step_m = 0;    ///< how far the second pass moved it, metres
  float confirm_step_deg = 0;  ///< ... and turned it, degrees
  double inlier_fraction = 0;  ///< of the last pass
  double residual_rms_m = 0;   ///< of the last pass
  /// Of the last pass's compute pixels, the share whose match lay too far or whose normals
  /// disagreed: pixels that met the map and did not fit it (holes and pixels that see past
  /// the map count in neither).
  double misfit_fraction = 0;
};

/// The rule's thresholds.
struct LocatedPoseRule {
  /// Largest move of the second pass: a pose ICP converged to moves less when tracked again
  /// from a raycast made there.
  float confirm_max_step_m = 0.02f;
  float confirm_max_step_deg = 2.0f;
  /// The second pass's residual RMS and inlier share (of the compute pixels): KFusion's accept
  /// test (2 cm, 15 %) lets a frame that follows a tracked one through at a wrong pose now and
  /// then, and a view tried from a keyframe 20–50 cm away passes it at a wrong pose far more
  /// often. Measured on real sequences (bench/RESULTS.md, "Localisation in a saved map"): right
  /// poses left 1.8–3.7 mm and 0.51–0.71 of the pixels, wrong ones that passed 1.3–1.8 cm on
  /// tum_fr1_xyz and 0.30–0.50 of the pixels on icl_office_kt0's walls.
  float max_rms_m = 0.01f;
  float min_inlier_fraction = 0.5f;
  /// The second pass's pixels that met the map and did not fit it (too far, or normals that
  /// disagree), as a share of the compute pixels; 1: no limit (setting localise_max_misfit).
  /// A wrong pose on a room's walls, reached by several passes or from a start moved around
  /// a keyframe, can leave a residual and an inlier share like a right one's, but it sets
  /// surfaces against others that do not fit. How much a right pose leaves depends on the
  /// map's detail and the sensor's noise, so there is no limit unless one is set: measured
  /// (bench/RESULTS.md, "Localisation in a saved map: candidates around the keyframes"),
  /// right poses left at most 0.008 of the pixels on icl_office_kt0 and 0.050 on tum_fr1_xyz
  /// and tum_fr1_rpy (256 voxels over 4–5 m), wrong ones on the office 0.091 and more, and
  /// right poses on the synthetic room mapped with 64 voxels 0.07–0.10.
  float max_misfit_fraction = 1.0f;
  /// Candidates that pass must agree this well, or the view is ambiguous.
  float agree_m = 0.05f;
  float agree_deg = 5.0f;
};

/// Distance, metres, and angle, degrees, between two camera poses.
void pose_difference(const Mat4f& a, const Mat4f& b, float& metres, float& degrees);

/// Whether an attempt's pose is one the rule would take: confirmed within the step, residual,
/// inlier and misfit limits (whether it agrees with the others is a separate question).
bool attempt_qualifies(const LocaliseAttempt& attempt, const LocatedPoseRule& rule = {});

/// The attempt whose pose locates the view, or −1 when none does: of the attempts confirmed
/// within the rule's step, residual and inlier limits, the one with the most inliers, provided
/// every other such attempt agrees with it.
int choose_located_attempt(const std::vector<LocaliseAttempt>& attempts,
                           const LocatedPoseRule& rule = {});

}  // namespace kfx
