#pragma once
/// Settings section `tracking`: the pyramid ICP and its accept test, KFusion's. Rows and
/// checks: tracking_settings.cpp.

#include <vector>

namespace kfx {

/// Loop closure while a run goes (src/loop/online_closure.hpp, docs/loop_closure.md).
enum class LoopClosureMode {
  kOff,     ///< none (the frame loop alone)
  kOnline,  ///< keyframes, loops verified between frames, a pose graph on a host thread
};

/// Section `tracking` of PipelineConfig.
struct TrackingSettings {
  int rate = 1;                                     ///< track frames f with f % rate == 0
  std::vector<int> iterations_per_level{10, 5, 4};  ///< ICP caps, finest level first
  float icp_threshold = 1e-5f;                      ///< stop a level when |x| is below this
  float dist_threshold_m = 0.1f;                    ///< association distance gate
  float normal_threshold = 0.8f;                    ///< association normal-dot gate
  float max_rms_error_m = 0.02f;                    ///< accept test: residual RMS limit
  float min_inlier_fraction = 0.15f;                ///< accept test: inliers / pixels
  float half_sample_range_m = 0.3f;                 ///< pyramid: robust half-sample range
  /// Relocalisation (localise/relocaliser.hpp): keyframes harvested while tracking is good,
  /// and a lost camera found again from them before anything more is integrated.
  bool relocalise = false;
  int relocalise_keyframes = 1000;  ///< keyframe database capacity
  int relocalise_ferns = 500;       ///< random ferns per keyframe code
  /// Loop closure (read by the run, not by the frame loop: the pose graph lives above it).
  LoopClosureMode loop_closure = LoopClosureMode::kOff;
  int loop_min_gap_frames = 200;  ///< a loop joins frames at least this many apart in time
  /// A good frame becomes a keyframe when this share of ferns differs from its nearest one's.
  float relocalise_harvest = 0.2f;
  /// A lost frame is aligned to each candidate keyframe's small depth image before the attempt,
  /// which starts at the keyframe's pose moved by the alignment (RelocaliserSettings).
  bool relocalise_align = true;
  /// Every frame is located alone in the loaded map from its nearest keyframes, with no memory
  /// of the previous frame's pose (Pipeline::localise); nothing is integrated.
  bool relocalise_each_frame = false;
  int localise_candidates = 5;  ///< nearest keyframes a frame located alone tries
  /// Of those, how many nearest are also tried from poses moved around theirs
  /// (localise/perturbed_poses.hpp) when none of the keyframes' own poses locates the view.
  int localise_perturb = 0;
  /// Passes after the first that may confirm a pose, each from where the last ended, until
  /// one barely moves it (1: exactly one).
  int localise_confirm_passes = 1;
  float localise_perturb_m = 0.1f;     ///< the move along each camera axis, metres
  float localise_perturb_deg = 10.0f;  ///< the turn about each camera axis, degrees
  /// The located pose's largest share of pixels set against surfaces they do not fit
  /// (LocatedPoseRule::max_misfit_fraction; 1: no limit).
  float localise_max_misfit = 1.0f;
  /// The located pose's least share of the pixels as inliers
  /// (LocatedPoseRule::min_inlier_fraction).
  float localise_min_inliers = 0.5f;
};

}  // namespace kfx
