#include "output/run_trajectory.hpp"

namespace kfx::output {

void write_run_trajectory(const std::string& path, const std::vector<io::StampedPose>& trajectory,
                          const std::string& input, const Mat4f& initial_pose,
                          const Intrinsics& k) {
  const Vec3f initial = initial_pose.translation_part();
  io::write_tum_trajectory(
      path, trajectory,
      {"kfx " + std::string(KFX_VERSION) + " trajectory of " + input,
       "pose AFTER each frame, camera to volume frame (first camera at " +
           std::to_string(initial.x) + " " + std::to_string(initial.y) + " " +
           std::to_string(initial.z) + " m), compute intrinsics " + std::to_string(k.fx) + " " +
           std::to_string(k.fy) + " " + std::to_string(k.cx) + " " + std::to_string(k.cy),
       "stamp tx ty tz qx qy qz qw"});
}

}  // namespace kfx::output
