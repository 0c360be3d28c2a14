#pragma once
/// The Kinect's depth noise model, read by tracking (icp_noise_weight) and by the raycast's
/// normals (raycast_normal_span_noise).

#include "core/platform.hpp"

namespace kfx {

/// Kinect axial depth noise σ(z) in metres at depth z (Nguyen, Izadi, Lovell 2012, eq. 2, the
/// surface facing the camera): 0.0012 + 0.0019 (z − 0.4)².
KFX_HD inline float kinect_axial_sigma_m(float z_m) {
  const float d = z_m - 0.4f;
  return 0.0012f + 0.0019f * d * d;
}

}  // namespace kfx
