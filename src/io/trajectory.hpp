#pragma once
/// Stamped poses and TUM-format trajectory files (`stamp tx ty tz qx qy qz qw`, camera to world),
/// and where a dataset's ground-truth trajectory is found.

#include <string>
#include <vector>

#include "core/math.hpp"

namespace kfx::io {

/// A timestamped rigid pose T_world_cam in double precision (host only).
struct StampedPose {
  double stamp_s = 0.0;
  double t[3] = {0, 0, 0};     ///< translation, metres
  double q[4] = {0, 0, 0, 1};  ///< unit quaternion (qx, qy, qz, qw)
};

/// Converts a float rigid pose matrix to a StampedPose.
StampedPose to_stamped_pose(double stamp_s, const Mat4f& T_world_cam);

/// Reads a TUM trajectory; '#' lines and blank lines are skipped. Throws kfx::Error naming the
/// file and line on a malformed line or when the file cannot be read.
std::vector<StampedPose> read_tum_trajectory(const std::string& path);

/// Writes a TUM trajectory atomically (temporary name, then rename). `header` lines are written
/// as '# ' comments first.
void write_tum_trajectory(const std::string& path, const std::vector<StampedPose>& poses,
                          const std::vector<std::string>& header = {});

/// The ground truth a reader should return: read from `override_path` when set (the user's
/// --gt), else from `found_path` ("" = none). `used_path` receives the file read ("" = none).
/// Throws kfx::Error naming the file when it cannot be read or has a malformed line.
std::vector<StampedPose> load_ground_truth(const std::string& override_path,
                                           const std::string& found_path, std::string* used_path);

/// The `*.gt.freiburg` files (ICL-NUIM's ground truth) directly in `folder`, sorted by name.
std::vector<std::string> find_freiburg_ground_truth(const std::string& folder);

}  // namespace kfx::io
