#pragma once
/// Moving the camera to a given pose between frames (a map loaded with its saved camera, or a
/// pose the caller gives): one body for both backends' state, which they apply on the host
/// between frames.

#include "core/platform.hpp"
#include "kernels/tracking_state.hpp"

namespace kfx {

/// Puts every pose of `s` at `T_world_cam` and forgets the motion and photometric history
/// (they belong to the old pose); the frame count and the map's counts are kept.
KFX_HD inline void move_camera(TrackingState& s, const Mat4f& T_world_cam) {
  s.T_world_cam = T_world_cam;
  s.T_world_cam_before = T_world_cam;
  s.T_world_cam_prev = T_world_cam;
  s.T_world_raycast = T_world_cam;
  s.tracked = 0;
  s.accepted_run = 0;
  s.rejected_since_accept = 0;
  s.intensity_reference = 0;
}

}  // namespace kfx
