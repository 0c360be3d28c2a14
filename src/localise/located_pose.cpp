#include "localise/located_pose.hpp"

#include <algorithm>
#include <cmath>

namespace kfx {

void pose_difference(const Mat4f& a, const Mat4f& b, float& metres, float& degrees) {
  const Mat4f d = rigid_inverse(a) * b;
  metres = length(d.translation_part());
  const float c =
      std::min(1.0f, std::max(-1.0f, (d.m[0][0] + d.m[1][1] + d.m[2][2] - 1.0f) * 0.5f));
  degrees = std::acos(c) * 57.29577951f;
}

bool attempt_qualifies(const LocaliseAttempt& a, const LocatedPoseRule& rule) {
  return a.accepted && a.confirmed && a.confirm_step_m <= rule.confirm_max_step_m &&
         a.confirm_step_deg <= rule.confirm_max_step_deg && a.residual_rms_m <= rule.max_rms_m &&
         a.inlier_fraction >= rule.min_inlier_fraction &&
         a.misfit_fraction <= rule.max_misfit_fraction;
}

int choose_located_attempt(const std::vector<LocaliseAttempt>& attempts,
                           const LocatedPoseRule& rule) {
  std::vector<size_t> confirmed;
  for (size_t i = 0; i < attempts.size(); ++i) {
    if (attempt_qualifies(attempts[i], rule)) confirmed.push_back(i);
  }
  if (confirmed.empty()) return -1;
  size_t best = confirmed[0];
  for (size_t i : confirmed) {
    if (attempts[i].inlier_fraction > attempts[best].inlier_fraction) best = i;
  }
  for (size_t i : confirmed) {
    float metres = 0, degrees = 0;
    pose_difference(attempts[best].T_world_cam, attempts[i].T_world_cam, metres, degrees);
    if (metres > rule.agree_m || degrees > rule.agree_deg) return -1;
  }
  return static_cast<int>(best);
}

}  // namespace kfx
