#pragma once
/// trajectory.txt of a run: TUM format, the pose after each frame, camera to volume frame.

#include <string>
#include <vector>

#include "core/camera.hpp"
#include "core/math.hpp"
#include "io/trajectory.hpp"

namespace kfx::output {

/// Writes `trajectory` to `path` with a header naming the input, the first camera's position in
/// the volume frame and the compute intrinsics (temporary name, renamed when complete).
void write_run_trajectory(const std::string& path, const std::vector<io::StampedPose>& trajectory,
                          const std::string& input, const Mat4f& initial_pose,
                          const Intrinsics& compute_k);

}  // namespace kfx::output
