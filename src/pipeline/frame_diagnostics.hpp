#pragma once
/// Warnings a user needs when a run goes wrong for a reason the tracker cannot name: the camera
/// outside the volume (through a face other than the one it started on), most of the depth outside
/// the volume or beyond the far plane, depth values implausible for the depth scale, a view that
/// pins the pose poorly along some direction (the ICP can slide there unnoticed). They only
/// observe (input depth and finished poses): nothing here changes what the pipeline computes.

#include <array>
#include <string>
#include <vector>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "kernels/tracking_constraint.hpp"
#include "pipeline/config.hpp"

namespace kfx {

/// The causes FrameDiagnostics recognises.
enum class FrameCause {
  kCameraOutsideVolume,
  kDepthOutsideVolume,
  kImplausibleDepth,
  kPoorlyConstrained,  ///< the ICP's weakest direction below kMinTrackingConstraint
  kCount
};

/// The cause's name in stats.json ("camera_outside_volume", ...).
const char* frame_cause_name(FrameCause cause);

/// A frame's depth, sampled on a coarse grid and back-projected into the camera frame: taken
/// when the frame is submitted, judged when its pose is known.
struct DepthSample {
  std::vector<Vec3f> p_cam_m;  ///< sampled valid pixels, camera frame, metres
  float median_depth_m = 0;    ///< median depth of the samples (0 when there are none)
  /// Share of the samples nearer than the near plane (raycast near_m), which the raycast never
  /// sees; and the same share were the depth 5× farther (a millimetre input read at TUM's
  /// 5000 units/m) or 5× nearer (TUM's PNGs read as millimetres).
  float near_share = 0;
  float near_share_if_5x_farther = 0;
  float near_share_if_5x_nearer = 0;
};

/// How often each cause was seen over a run.
struct FrameCauseCount {
  int frames = 0;        ///< frames with this cause
  int first_frame = -1;  ///< the first of them (−1: none)
  int warnings = 0;      ///< warnings given (at most kMaxWarningsPerCause)
};

/// Watches a run's frames for the causes above and says when one begins, naming the frame:
/// one warning per stretch of frames with the cause (a stretch ends after kFramesToEndStretch
/// frames without it), at most kMaxWarningsPerCause per cause, so
/// a long loss does not flood the output.
class FrameDiagnostics {
 public:
  /// Warnings per cause and run; later stretches are counted, not shown.
  static constexpr int kMaxWarningsPerCause = 3;
  /// Median depth outside this range (metres) is implausible for an RGB-D camera (Kinect-type
  /// sensors measure to about 4-5 m; the shared TUM and ICL-NUIM sequences' medians stay below
  /// 3.7 m): most likely the depth scale is wrong (TUM's 5000 units/m read as 1000 gives 5×).
  static constexpr float kPlausibleMedianDepthMin_m = 0.2f;
  static constexpr float kPlausibleMedianDepthMax_m = 5.0f;
  /// "Most" of the depth: more than this fraction of the valid samples.
  static constexpr float kMostDepthFraction = 0.75f;
  /// The depth is also implausible when more than this share of it lies nearer than the near
  /// plane while 5× farther or nearer it would be plausible: a median inside the band can
  /// still be a wrong scale (millimetre depth read at 5000 units/m: a room at 1.9 m reads 0.38 m,
  /// most of it nearer than the 0.4 m near plane). Depth scales in use are 1000 (Kinect
  /// drivers, RealSense, SLAMBench's .raw) and 5000 units/m (TUM, ICL-NUIM): a factor of 5.
  static constexpr float kNearShareImplausible = 0.5f;
  static constexpr float kScaleFactor = 5.0f;
  /// A stretch of frames with a cause ends after this many frames without it.
  static constexpr int kFramesToEndStretch = 10;
  /// Every this many pixels in x and y are sampled (a few thousand points at 640×480).
  static constexpr int kSampleStridePx = 8;
  /// Tracking is poorly constrained when the weakest ICP direction of every tracked frame
  /// (TrackingConstraint::eigenvalues[0], m² of mean squared residual per unit step) stays below
  /// kMinTrackingConstraint for kPoorlyConstrainedFrames tracked frames in a row. Single frames
  /// dip that low on sequences that track well (TUM fr1_rpy: 12 in a row at most, fr1_xyz: 16
  /// frames in all); the synthetic house's C door, where the pose slid 0.5 m, stayed below it
  /// for 85. See docs/tracking-constraint.md and bench/RESULTS.md, "tracking on the house".
  static constexpr float kMinTrackingConstraint = 0.004f;
  static constexpr int kPoorlyConstrainedFrames = 30;

  /// `input_intrinsics` at input size, as the frames' depth images are.
  FrameDiagnostics(const PipelineConfig& config, const Intrinsics& input_intrinsics);

  /// Samples a frame's input depth (millimetres, input size).
  DepthSample sample(ImageView<const uint16_t> depth_mm) const;

  /// Judges frame `frame` (the input's number) from its depth sample, the camera pose after
  /// it (volume frame) and, when it was tracked, how well its ICP pinned the pose
  /// (`constraint`; null when tracking did not run or did not hold, which leaves the count of
  /// poorly constrained frames in a row as it is); returns the warnings to show now, one line
  /// each, naming the frame.
  std::vector<std::string> check(int frame, const DepthSample& depth, const Mat4f& T_world_cam,
                                 const TrackingConstraint* constraint = nullptr);

  /// Per cause, how often it was seen.
  const FrameCauseCount& count(FrameCause cause) const { return counts_[static_cast<int>(cause)]; }

 private:
  /// Whether depth of this median (metres) and share nearer than the near plane is plausible.
  static bool depth_plausible(float median_m, float near_share);
  /// The implausible-depth warning for `depth`, with the scale that would fit, if any.
  std::string implausible_depth_words(const DepthSample& depth) const;
  /// Records that `cause` is (or is not) present at `frame`; a warning when a stretch begins.
  void note(FrameCause cause, bool present, int frame, const std::string& message,
            std::vector<std::string>& warnings);

  Intrinsics k_;
  float volume_size_m_;
  bool has_faces_;  ///< a dense cube; a block map (volume=blocks) has no faces to leave
  std::array<float, 3> start_factor_;  ///< the first camera at start_factor_ · volume size
  float far_m_;
  int weak_run_ = 0;                    ///< tracked frames in a row below kMinTrackingConstraint
  int weak_run_first_ = -1;             ///< the first of them
  float weak_run_lowest_ = 0;           ///< the lowest figure among them
  TrackingConstraint weak_run_last_{};  ///< the last of them
  double depth_scale_per_m_;            ///< 0: the format's, not known here
  float near_m_;                        ///< the raycast's near plane
  std::array<FrameCauseCount, static_cast<int>(FrameCause::kCount)> counts_{};
  std::array<bool, static_cast<int>(FrameCause::kCount)> active_{};         ///< in a stretch
  std::array<int, static_cast<int>(FrameCause::kCount)> frames_without_{};  ///< since the last
};

}  // namespace kfx
