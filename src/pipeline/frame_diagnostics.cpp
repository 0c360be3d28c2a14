#include "pipeline/frame_diagnostics.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

namespace kfx {
namespace {

bool inside_cube(Vec3f p, float size_m) {
  return p.x >= 0 && p.y >= 0 && p.z >= 0 && p.x <= size_m && p.y <= size_m && p.z <= size_m;
}

/// Whether the camera has left the volume through a face it did not start on. The first camera
/// sits on a face (SLAMBench's start, z = 0) and looks in through it: moving back behind that
/// face is normal (TUM fr1_xyz and ICL-NUIM kt0 go 12-16 cm behind it), crossing another is not.
bool camera_left_volume(Vec3f c, float size_m, const std::array<float, 3>& start_factor) {
  const float p[3] = {c.x, c.y, c.z};
  for (int axis = 0; axis < 3; ++axis) {
    if (p[axis] < 0 && start_factor[axis] > 0) return true;
    if (p[axis] > size_m && start_factor[axis] < 1) return true;
  }
  return false;
}

/// The weakest direction in words: its larger half (translation or rotation) by its main axis,
/// and the other half's main axis when that half is not negligible.
std::string weakest_direction_words(const TrackingConstraint& c) {
  // The two halves' lengths: rotations count at 1 m (kernels/tracking_constraint.hpp).
  const float* v = c.weakest;
  const float t = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  const float w = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5]);
  static const char* const kAxis[3] = {"x (right)", "y (down)", "z (forward)"};
  const auto main_axis = [](const float* a) {
    int k = 0;
    for (int i = 1; i < 3; ++i) {
      if (std::fabs(a[i]) > std::fabs(a[k])) k = i;
    }
    return k;
  };
  std::ostringstream s;
  const float* first = t >= w ? v : v + 3;
  const float* second = t >= w ? v + 3 : v;
  s << (t >= w ? "translation along the camera's " : "rotation about the camera's ")
    << kAxis[main_axis(first)];
  const float rest = t >= w ? w : t;
  if (rest > 0.1f) {
    s << " with " << (t >= w ? "rotation about its " : "translation along its ")
      << kAxis[main_axis(second)];
  }
  return s.str();
}

}  // namespace

const char* frame_cause_name(FrameCause cause) {
  switch (cause) {
    case FrameCause::kCameraOutsideVolume:
      return "camera_outside_volume";
    case FrameCause::kDepthOutsideVolume:
      return "depth_outside_volume";
    case FrameCause::kImplausibleDepth:
      return "implausible_depth";
    case FrameCause::kPoorlyConstrained:
      return "poorly_constrained_tracking";
    case FrameCause::kCount:
      break;
  }
  return "?";
}

FrameDiagnostics::FrameDiagnostics(const PipelineConfig& config, const Intrinsics& input_intrinsics)
    : k_(input_intrinsics),
      volume_size_m_(config.volume.size_m),
      has_faces_(config.volume.kind == MapKind::kDense),
      start_factor_(config.volume.init_pose_factor),
      far_m_(config.raycast.far_m),
      depth_scale_per_m_(config.input.depth_scale_per_m),
      near_m_(config.raycast.near_m) {}

DepthSample FrameDiagnostics::sample(ImageView<const uint16_t> depth_mm) const {
  DepthSample s;
  std::vector<float> depths_m;
  for (int v = kSampleStridePx / 2; v < depth_mm.height; v += kSampleStridePx) {
    for (int u = kSampleStridePx / 2; u < depth_mm.width; u += kSampleStridePx) {
      const uint16_t d = depth_mm(u, v);
      if (d == 0) continue;
      const float z_m = d * 0.001f;
      s.p_cam_m.push_back({(u - k_.cx) / k_.fx * z_m, (v - k_.cy) / k_.fy * z_m, z_m});
      depths_m.push_back(z_m);
    }
  }
  if (!depths_m.empty()) {
    const auto mid = depths_m.begin() + depths_m.size() / 2;
    std::nth_element(depths_m.begin(), mid, depths_m.end());
    s.median_depth_m = *mid;
    // The shares nearer than the near plane at this scale and at the two others, in one pass.
    size_t nearer = 0, nearer_if_farther = 0, nearer_if_nearer = 0;
    for (float z : depths_m) {
      nearer += z < near_m_;
      nearer_if_farther += z * kScaleFactor < near_m_;
      nearer_if_nearer += z * (1.0f / kScaleFactor) < near_m_;
    }
    const float n = static_cast<float>(depths_m.size());
    s.near_share = nearer / n;
    s.near_share_if_5x_farther = nearer_if_farther / n;
    s.near_share_if_5x_nearer = nearer_if_nearer / n;
  }
  return s;
}

std::vector<std::string> FrameDiagnostics::check(int frame, const DepthSample& depth,
                                                 const Mat4f& T_world_cam,
                                                 const TrackingConstraint* constraint) {
  std::vector<std::string> warnings;
  const float size = volume_size_m_;
  // The camera: the volume spans [0, size] on each axis of the volume (world) frame.
  const Vec3f c = T_world_cam.translation_part();
  {
    std::ostringstream m;
    m.precision(3);
    m << "the camera is outside the volume (at " << c.x << ", " << c.y << ", " << c.z
      << " m; the volume spans 0 to " << size
      << " m on each axis): what it sees there is neither tracked against nor integrated; a "
         "larger volume (-s) or another start position (-p) keeps it inside";
    note(FrameCause::kCameraOutsideVolume, has_faces_ && camera_left_volume(c, size, start_factor_),
         frame, m.str(), warnings);
  }
  // The depth: where its points land in the volume frame.
  if (!depth.p_cam_m.empty()) {
    int outside = 0;
    for (const Vec3f& p : depth.p_cam_m) {
      if (p.z > far_m_ || (has_faces_ && !inside_cube(T_world_cam * p, size))) ++outside;
    }
    const float fraction = static_cast<float>(outside) / depth.p_cam_m.size();
    std::ostringstream m;
    m.precision(3);
    m << static_cast<int>(100 * fraction + 0.5f)
      << " % of the depth lies outside the volume or beyond the far plane (median depth "
      << depth.median_depth_m << " m; the volume spans 0 to " << size
      << " m on each axis, far plane " << far_m_
      << " m): little can be integrated or tracked; check the volume size (-s), the start "
         "position (-p) and the depth scale";
    note(FrameCause::kDepthOutsideVolume, fraction > kMostDepthFraction, frame, m.str(), warnings);
    note(FrameCause::kImplausibleDepth, !depth_plausible(depth.median_depth_m, depth.near_share),
         frame, implausible_depth_words(depth), warnings);
  }
  // The ICP's weakest direction: a view with too little geometry across it (a flat wall, a
  // corridor, a floor and far walls beyond the sensor's range) lets the pose slide there while
  // every frame passes the accept test.
  if (constraint != nullptr) {
    const float c = constraint->eigenvalues[0];
    if (c < kMinTrackingConstraint) {
      if (weak_run_ == 0) weak_run_first_ = frame;
      weak_run_lowest_ = weak_run_ == 0 ? c : std::min(weak_run_lowest_, c);
      ++weak_run_;
      weak_run_last_ = *constraint;
    } else {
      weak_run_ = 0;
    }
  }
  {
    const bool poor = weak_run_ >= kPoorlyConstrainedFrames;
    std::ostringstream m;
    if (poor) {
      m.precision(2);
      m << "tracking has been poorly constrained since frame " << weak_run_first_ << " ("
        << weak_run_ << " tracked frames with the ICP's weakest direction below "
        << kMinTrackingConstraint << ", lowest " << weak_run_lowest_ << "; now "
        << weakest_direction_words(weak_run_last_)
        << "): the view has too little geometry across that direction, so the pose may slide "
           "along it unnoticed (every frame still passes the accept test)";
    }
    note(FrameCause::kPoorlyConstrained, poor, frame, m.str(), warnings);
  }
  return warnings;
}

bool FrameDiagnostics::depth_plausible(float median_m, float near_share) {
  return median_m >= kPlausibleMedianDepthMin_m && median_m <= kPlausibleMedianDepthMax_m &&
         near_share <= kNearShareImplausible;
}

std::string FrameDiagnostics::implausible_depth_words(const DepthSample& depth) const {
  const auto units = [](double per_m) {
    return std::to_string(static_cast<long long>(per_m + 0.5)) + " units/m";
  };
  std::ostringstream m;
  m.precision(3);
  m << "the depth is implausible for an RGB-D camera (median " << depth.median_depth_m << " m, "
    << static_cast<int>(100 * depth.near_share + 0.5f) << " % of it nearer than the " << near_m_
    << " m near plane; expected a median of " << kPlausibleMedianDepthMin_m << " to "
    << kPlausibleMedianDepthMax_m << " m with at most "
    << static_cast<int>(100 * kNearShareImplausible) << " % nearer) at the depth scale "
    << (depth_scale_per_m_ > 0 ? units(depth_scale_per_m_) : std::string("used"));
  // The scale that would make the frame plausible, if one of the two in use does.
  const float farther_m = depth.median_depth_m * kScaleFactor;
  const float nearer_m = depth.median_depth_m / kScaleFactor;
  // Only a scale in use is named (from a known scale: the other of 1000 and 5000).
  const auto in_use = [&](float factor) {
    if (depth_scale_per_m_ <= 0) return true;
    const double other = depth_scale_per_m_ / factor;
    return std::fabs(other - 1000.0) < 0.5 || std::fabs(other - 5000.0) < 0.5;
  };
  const bool fits_farther =
      in_use(kScaleFactor) && depth_plausible(farther_m, depth.near_share_if_5x_farther);
  const bool fits_nearer =
      in_use(1.0f / kScaleFactor) && depth_plausible(nearer_m, depth.near_share_if_5x_nearer);
  if (fits_farther || fits_nearer) {
    const float factor = fits_farther ? kScaleFactor : 1.0f / kScaleFactor;
    m << "; "
      << (depth_scale_per_m_ > 0 ? units(depth_scale_per_m_ / factor)
                                 : (fits_farther ? std::string("a 5x smaller scale")
                                                 : std::string("a 5x larger scale")))
      << " would fit (median " << depth.median_depth_m * factor << " m, "
      << static_cast<int>(
             100 * (fits_farther ? depth.near_share_if_5x_farther : depth.near_share_if_5x_nearer) +
             0.5f)
      << " % nearer than the near plane)";
  }
  m << ": is --depth-scale right? (millimetre depth, as Kinect drivers and RealSense write it: "
       "1000 units/m; TUM RGB-D and ICL-NUIM PNGs: 5000 units/m)";
  return m.str();
}

void FrameDiagnostics::note(FrameCause cause, bool present, int frame, const std::string& message,
                            std::vector<std::string>& warnings) {
  const int i = static_cast<int>(cause);
  FrameCauseCount& count = counts_[i];
  const bool begins = present && !active_[i];
  // A stretch ends only after kFramesToEndStretch frames without the cause, so a figure
  // hovering at its bound does not warn again every other frame.
  if (present) {
    active_[i] = true;
    frames_without_[i] = 0;
  } else if (active_[i] && ++frames_without_[i] >= kFramesToEndStretch) {
    active_[i] = false;
  }
  if (!present) return;
  ++count.frames;
  if (count.first_frame < 0) count.first_frame = frame;
  if (!begins || count.warnings >= kMaxWarningsPerCause) return;
  ++count.warnings;
  std::string line = "frame " + std::to_string(frame) + ": " + message;
  if (count.warnings == kMaxWarningsPerCause) {
    line += " (further stretches of this are not shown; stats.json counts them)";
  }
  warnings.push_back(line);
}

}  // namespace kfx
