#pragma once
/// Relative pose error over a fixed number of frames (Sturm et al., IROS 2012; TUM's
/// evaluate_rpe.py with a frame delta): drift of the relative motion, no global alignment.

#include <Eigen/Geometry>
#include <vector>

#include "eval/associate.hpp"
#include "eval/ate.hpp"
#include "io/trajectory.hpp"

namespace kfx::eval {

/// RPE per pair of associated poses (i, i + delta_frames) and its statistics.
struct RpeResult {
  int delta_frames = 1;                ///< step between the two poses, in associated pairs
  std::vector<double> trans_errors_m;  ///< |translation(E_i)|, metres
  std::vector<double> rot_errors_deg;  ///< rotation angle of E_i, degrees
  ErrorStats trans_m;                  ///< statistics of trans_errors_m, metres
  ErrorStats rot_deg;                  ///< statistics of rot_errors_deg, degrees
};

/// The rigid pose T_world_cam of a StampedPose (quaternion normalised). Throws kfx::Error when
/// the quaternion has zero or non-finite norm.
Eigen::Isometry3d to_isometry(const io::StampedPose& pose);

/// Conjugates a pose by the y mirror M = diag(1, −1, 1): M·T·M, the same motion seen in the
/// mirrored world and camera (translation y negated, rotation entries r01 r10 r12 r21 negated).
Eigen::Isometry3d mirror_y(const Eigen::Isometry3d& pose);

/// RPE of associated trajectories: for consecutive pairs i and i + delta_frames (in the order of
/// `association.pairs`) with ground truth Q and estimate P, E_i = (Q_i⁻¹ Q_{i+δ})⁻¹ (P_i⁻¹
/// P_{i+δ}); the translational error is |t(E_i)| and the rotational error the angle of R(E_i). With
/// `flip_y` every estimate pose is mirrored first (mirror_y). Throws kfx::Error when
/// `delta_frames` < 1 or there are not more pairs than `delta_frames`.
RpeResult compute_rpe(const std::vector<io::StampedPose>& est,
                      const std::vector<io::StampedPose>& gt, const Association& association,
                      int delta_frames, bool flip_y);

}  // namespace kfx::eval
