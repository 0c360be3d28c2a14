#pragma once
/// The loop room's double-precision poses and the frame loop's float matrices, both ways.

#include "core/math.hpp"
#include "loop/pose_graph.hpp"

namespace kfx::loop {

/// A pose as the frame loop's matrix (camera to volume frame).
Mat4f to_mat4f(const Pose3d& pose);
/// The frame loop's matrix as a pose, its rotation made orthonormal again (the float matrix
/// drifts from orthonormal in its last bits).
Pose3d to_pose3d(const Mat4f& m);

}  // namespace kfx::loop
