#include "localise/perturbed_poses.hpp"

#include <cmath>

namespace kfx {
namespace {

/// A rotation by `radians` about camera axis `axis` (0 x, 1 y, 2 z).
Mat4f axis_rotation(int axis, float radians) {
  Mat4f r = Mat4f::identity();
  const int i = (axis + 1) % 3, j = (axis + 2) % 3;
  const float c = std::cos(radians), s = std::sin(radians);
  r.m[i][i] = c;
  r.m[i][j] = -s;
  r.m[j][i] = s;
  r.m[j][j] = c;
  return r;
}

}  // namespace

std::vector<Mat4f> perturbed_poses(const Mat4f& T_world_cam, float step_m, float step_deg) {
  std::vector<Mat4f> poses;
  // Right-multiplied: the moves are in the camera's own frame, so "along its view" and "turned
  // about its centre" mean the same for every keyframe.
  if (step_m > 0.0f) {
    for (int axis = 0; axis < 3; ++axis) {
      for (float sign : {1.0f, -1.0f}) {
        Vec3f t{0.0f, 0.0f, 0.0f};
        (axis == 0 ? t.x : axis == 1 ? t.y : t.z) = sign * step_m;
        poses.push_back(T_world_cam * Mat4f::translation(t));
      }
    }
  }
  if (step_deg > 0.0f) {
    const float radians = step_deg * 0.01745329252f;
    for (int axis = 0; axis < 3; ++axis) {
      for (float sign : {1.0f, -1.0f}) {
        poses.push_back(T_world_cam * axis_rotation(axis, sign * radians));
      }
    }
  }
  return poses;
}

}  // namespace kfx
