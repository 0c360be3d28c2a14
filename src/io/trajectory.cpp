/// TUM-format trajectory files and pose conversion.

#include "io/trajectory.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "core/platform.hpp"
#include "io/atomic_file.hpp"
#include "io/text_listing.hpp"

namespace kfx::io {
namespace {

/// Quaternions read from files must have a norm within this of 1 before they are normalised:
/// files print 6 to 9 digits, so anything further off is a corrupt line, not rounding.
constexpr double kQuaternionNormTolerance = 1e-2;

/// Stamps that are exact integers below this are printed without decimals (ICL-NUIM frame ids);
/// others with 6 decimals (TUM's microsecond stamps).
constexpr double kMaxIntegerStamp = 1e15;

void append_stamp(std::string& out, double stamp_s) {
  char buffer[64];
  if (stamp_s == std::floor(stamp_s) && std::fabs(stamp_s) < kMaxIntegerStamp) {
    std::snprintf(buffer, sizeof(buffer), "%.0f", stamp_s);
  } else {
    std::snprintf(buffer, sizeof(buffer), "%.6f", stamp_s);
  }
  out += buffer;
}

}  // namespace

StampedPose to_stamped_pose(double stamp_s, const Mat4f& T_world_cam) {
  Eigen::Matrix3d rotation;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) rotation(i, j) = T_world_cam.m[i][j];
  }
  Eigen::Quaterniond q(rotation);
  q.normalize();
  // One of the two equivalent signs, so equal rotations print equally: qw >= 0.
  if (q.w() < 0) q.coeffs() *= -1.0;
  StampedPose pose;
  pose.stamp_s = stamp_s;
  for (int i = 0; i < 3; ++i) pose.t[i] = T_world_cam.m[i][3];
  pose.q[0] = q.x();
  pose.q[1] = q.y();
  pose.q[2] = q.z();
  pose.q[3] = q.w();
  return pose;
}

std::vector<StampedPose> read_tum_trajectory(const std::string& path) {
  const std::vector<TextLine> lines = read_text_lines(path, "trajectory");
  std::vector<StampedPose> poses;
  poses.reserve(lines.size());
  for (const TextLine& line : lines) {
    KFX_CHECK(line.fields.size() == 8, "malformed line "
                                           << line.line_number << " of trajectory '" << path
                                           << "': expected 8 fields (stamp tx ty tz qx qy qz qw), "
                                              "found "
                                           << line.fields.size());
    StampedPose pose;
    pose.stamp_s = parse_double_field(line, 0, path, "timestamp");
    static const char* const kNames[7] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};
    double values[7];
    for (int i = 0; i < 7; ++i) values[i] = parse_double_field(line, i + 1, path, kNames[i]);
    const double norm = std::sqrt(values[3] * values[3] + values[4] * values[4] +
                                  values[5] * values[5] + values[6] * values[6]);
    KFX_CHECK(std::fabs(norm - 1.0) <= kQuaternionNormTolerance,
              "malformed line " << line.line_number << " of trajectory '" << path
                                << "': quaternion norm " << norm << " is not 1");
    for (int i = 0; i < 3; ++i) pose.t[i] = values[i];
    for (int i = 0; i < 4; ++i) pose.q[i] = values[3 + i] / norm;
    poses.push_back(pose);
  }
  return poses;
}

void write_tum_trajectory(const std::string& path, const std::vector<StampedPose>& poses,
                          const std::vector<std::string>& header) {
  std::string out;
  out.reserve(96 * (poses.size() + header.size()));
  for (const std::string& line : header) {
    out += "# ";
    out += line;
    out += '\n';
  }
  char buffer[256];
  for (const StampedPose& pose : poses) {
    append_stamp(out, pose.stamp_s);
    std::snprintf(buffer, sizeof(buffer), " %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", pose.t[0],
                  pose.t[1], pose.t[2], pose.q[0], pose.q[1], pose.q[2], pose.q[3]);
    out += buffer;
  }
  AtomicFile file(path);
  file.stream() << out;
  file.commit();
}

std::vector<StampedPose> load_ground_truth(const std::string& override_path,
                                           const std::string& found_path, std::string* used_path) {
  *used_path = override_path.empty() ? found_path : override_path;
  if (used_path->empty()) return {};
  std::vector<StampedPose> poses = read_tum_trajectory(*used_path);
  // An empty ground truth would silently mean "no ATE"; `kfx eval` refuses the same file.
  KFX_CHECK(!poses.empty(),
            "ground-truth trajectory '"
                << *used_path << "' holds no pose (no data line)"
                << (override_path.empty() ? "; remove it to run without ground truth" : ""));
  return poses;
}

std::vector<std::string> find_freiburg_ground_truth(const std::string& folder) {
  std::vector<std::string> found;
  std::error_code error;
  const std::string suffix = ".gt.freiburg";
  for (std::filesystem::directory_iterator it(folder, error), end; !error && it != end;
       it.increment(error)) {
    const std::string name = it->path().filename().string();
    if (name.size() > suffix.size() &&
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0 &&
        it->is_regular_file(error)) {
      found.push_back(it->path().string());
    }
  }
  std::sort(found.begin(), found.end());
  return found;
}

}  // namespace kfx::io
