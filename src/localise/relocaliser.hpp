#pragma once
/// Relocalisation: finding the camera again after tracking is lost, or in a map loaded from a
/// file. One floor above the frame loop (DESIGN.md): the pipeline tells it what each collected
/// frame did and asks it what the next submitted frame should do; it never touches the map.
///
/// While tracking is good it harvests keyframes (localise/keyframe_database.hpp): a frame whose
/// view differs enough from its nearest keyframe is filed with its pose. When a frame fails the
/// accept test the camera is lost: integration stops, and the next frames attempt candidate
/// poses, one at a time: the nearest keyframes of the last lost frame's view and the last good
/// pose, a keyframe's moved by the attempt frame's alignment to its small depth image
/// (RelocaliserSettings::align_candidates). An attempt frame moves the camera to the candidate,
/// raycasts the map from it and tracks that same frame against the raycast. A frame that passes the
/// accept test starts a verification: the frames after it are tracked as usual and must pass too,
/// each moving the camera by no more than a frame's plausible motion, before the camera counts as
/// found and integration resumes. Any failure on the way goes back to lost and the next candidate.

#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "localise/keyframe_database.hpp"

namespace kfx {

/// Settings of the relocaliser (settings relocalise_*; docs/settings.md).
struct RelocaliserSettings {
  int fern_count = 500;  ///< ferns per code
  int keyframe_capacity = 1000;
  /// A good frame becomes a keyframe when the share of ferns whose codes differ from its
  /// nearest keyframe's exceeds this (InfiniTAM's 0.2).
  float harvest_dissimilarity = 0.2f;
  /// Accepted frames in a row (the attempt's included) before the camera counts as found.
  int verify_frames = 3;
  /// Nearest keyframes tried per lost view.
  int candidates = 3;
  /// Largest motion between two verification frames, metres and degrees: more is a jump no
  /// camera makes in a frame, so the accepted pose is not trusted.
  float verify_max_step_m = 0.10f;
  float verify_max_step_deg = 10.0f;
  /// A frame whose code (of its input depth, before it is submitted: submitted_view()) differs
  /// from the last submitted frame's in more than this share of ferns is a view jump (frames
  /// missing, the camera moved while covered): the accept test can pass there at a wrong pose,
  /// so a tracking camera counts as lost from that frame on, before it is integrated, and only
  /// candidates from keyframes that look like the new view are tried. Measured (bench/RESULTS.md,
  /// "Relocalisation"): up to 0.13 between tum_fr1_xyz's frames, 0.34 on tum_fr1_rpy's fast
  /// turns, 0.43 at a 48 cm, 26° cut.
  float view_jump_dissimilarity = 0.4f;
  /// A frame whose code differs from the last submitted frame's in more than this share of
  /// ferns (but no more than view_jump_dissimilarity) is doubtful: it, and the frame submitted
  /// behind it (tracked on from its pose), are not integrated until it is collected and its own
  /// tracking shows whether it jumped (frame_jumped() below). Measured (bench/RESULTS.md, "The
  /// view jump the ICP sees"): 0.24 at a 71° turn cut out of tum_fr1_rpy, above 0.2 on two of
  /// rpy's tracked frames (fast turns, 0.20 and 0.21), never on tum_fr1_xyz (0.13) or
  /// icl_office_kt0 (0.04).
  float view_doubt_dissimilarity = 0.2f;
  /// A tracked frame after a tracked frame jumped when the ICP's fit fell apart at it: its
  /// residual RMS over this many times the last good frame's while its inlier fraction fell
  /// below view_jump_inlier_ratio times that frame's (a view the map does not explain and a
  /// minimum reached far from the truth). The same test refuses a lost camera's candidate
  /// whose fit fell apart so, however it passed the accept test, with its inliers counted over
  /// the pixels the map pairs rather than the view (a candidate sees the map over part of its
  /// view). Measured: tracked frames of the three shared sequences at most 1.64 and at least
  /// 0.64 against the last good frame (never both past the bounds), 5.1 and 0.30 at the rpy
  /// cut, 4–5 and 0.4–0.5 at candidates the accept test passed 10–20 cm off.
  float view_jump_residual_ratio = 2.5f;
  float view_jump_inlier_ratio = 0.6f;
  /// Farthest an attempt's ICP may take the camera from its candidate's pose, metres, for the
  /// pose it reached to start a verification. A candidate is tried because its view looks
  /// like the frame's, so the camera is near it; ICP that ends far away slid along the scene
  /// (a wall fits at many poses) into a wrong minimum that the accept test and the frames
  /// tracked on from it can pass. Measured (bench/RESULTS.md, "Attempts that end far from
  /// their candidate"): right attempts on the cut real sequences ended 0.03–0.14 m from their
  /// keyframe, the office's false ones 1.2 and 1.5 m, the rejected ones on tum_fr1_rpy
  /// 0.65–0.98 m. The angle is not bounded: a right attempt turned 37°. With align_candidates
  /// the attempt starts at the keyframe's pose moved by the lost view's alignment to it, and the
  /// reach is measured from there: it guards against the map ICP sliding, not the alignment
  /// (which is bounded by the same distance from the keyframe on its own).
  float candidate_reach_m = 0.5f;
  /// A frame that starts or continues a verification disagrees with the map when the share of
  /// its pixels that the ICP paired with a map point farther than its distance threshold (10 cm
  /// in KFusion) exceeds both this floor and candidate_too_far_ratio times the last good frame's
  /// share: a pose that fits one wall while the rest of the view lies in the wrong place. The
  /// inliers and residual of such a pose can look like good tracking's (a wall fits at many
  /// poses). Measured (bench/RESULTS.md, "Attempts that end far from their candidate"): good
  /// tracking 0.002 (median) on icl_office_kt0, 0.008–0.011 on tum_fr1_xyz and tum_fr1_rpy;
  /// right relocalisations up to 0.019 at up to 2 times the last good frame's; the office's
  /// false ones 0.012–0.19 at 6–90 times.
  float candidate_too_far_floor = 0.01f;
  float candidate_too_far_ratio = 4.0f;
  /// Align the frame an attempt is made on to the candidate keyframe's small depth image
  /// (localise/small_depth_alignment.hpp) and start the attempt at the keyframe's pose moved
  /// by that alignment, instead of at the keyframe's pose (setting relocalise_align). The
  /// keyframe's own pose stays the start when it has no image (a map saved without them), the
  /// alignment paired less than align_min_inliers of the frame's small pixels (it found no
  /// overlap), or it moved the camera farther than candidate_reach_m (views that look alike are
  /// near each other; farther is the small ICP sliding along a wall). The share paired does
  /// not tell right alignments from wrong ones: on icl_office_kt0's cut, right ones (1–4 cm,
  /// 1–2° from the truth) paired 0.07–0.34 at a 5 cm gate, wrong ones 0.2–0.34, and those that
  /// found nothing 0.01–0.03 (bench/RESULTS.md, "Candidates aligned to the lost view"); the
  /// attempt's own tests against the map judge the rest.
  bool align_candidates = true;
  float align_min_inliers = 0.05f;
};

/// What the relocaliser reads of one collected frame.
struct RelocaliserObservation {
  bool tracking_ran = false;
  bool tracked = false;            ///< the accept test passed
  bool good = false;               ///< the tracking state is good (not poor, not lost)
  bool attempt = false;            ///< the frame was an attempt (plan().attempt)
  Mat4f T_world_cam;               ///< pose after the frame
  int frame = 0;                   ///< the pipeline's frame number
  double inlier_fraction = 0;      ///< the ICP's last iteration's inliers / compute pixels
  double residual_rms_m = 0;       ///< ... and its residual RMS over them, metres
  double too_far_fraction = 0;     ///< ... and its pixels paired too far away / compute pixels
  double bad_normal_fraction = 0;  ///< ... and paired with a disagreeing normal / compute pixels
};

/// What the next submitted frame does.
struct RelocaliserPlan {
  bool integrate = true;  ///< integration allowed (false until the camera is found)
  bool attempt = false;   ///< move to T_world_cam, raycast, then track this frame
  Mat4f T_world_cam;
};

/// The relocaliser's figures for stats.json.
struct RelocaliserFigures {
  int keyframes = 0;
  int attempts = 0;             ///< attempt frames collected
  int relocalisations = 0;      ///< times the camera was found after being lost
  uint64_t memory_bytes = 0;    ///< the keyframe database's
  uint64_t capacity_bytes = 0;  ///< ... when full
  double host_ms = 0;           ///< host time: codes, queries, harvesting, alignments
  int alignments = 0;           ///< candidates aligned to a lost frame (align_candidates)
  int aligned_starts = 0;       ///< ... whose attempt started at the aligned pose
  double max_alignment_ms = 0;  ///< host time of the slowest alignment
  bool can_relocalise = true;   ///< false with a loaded map that came without keyframes
};

class Relocaliser {
 public:
  Relocaliser() = default;
  /// For small depth images of width × height pixels.
  Relocaliser(const RelocaliserSettings& settings, int small_width_px, int small_height_px);

  /// The small image's intrinsics (small_depth_intrinsics()), which aligning candidates needs;
  /// without them candidates start at their keyframes' poses.
  void set_small_intrinsics(const Intrinsics& small_k) { small_k_ = small_k; }
  /// Where an attempt from keyframe `keyframe` starts for the view whose small image is
  /// `small_mm`: the keyframe's pose, moved by the view's alignment to it when
  /// align_candidates is set and the alignment holds (RelocaliserSettings::align_candidates).
  Mat4f candidate_pose(int keyframe, ImageView<const uint16_t> small_mm);

  /// Starts over: empty database, tracking (the first pose is given).
  void reset();
  /// The camera was put at a pose the caller trusts (set_pose): tracking, nothing to verify.
  void trust_pose(const Mat4f& T_world_cam);
  /// A map was loaded: its keyframe database replaces this one's, if it came with one that
  /// matches this relocaliser's image size and fern count; else the database is emptied and
  /// can_relocalise() is false (harvesting starts again once the camera is found).
  void adopt_keyframes(std::optional<KeyframeDatabase> keyframes);
  /// Lost until found, `T_world_cam` (e.g. the camera a loaded map was saved with) the first
  /// candidate.
  void start_lost(const Mat4f& T_world_cam);

  /// Takes in the small image of frame `frame`'s input depth (input_small_depth.hpp) before the
  /// frame is planned and submitted; true when it is a view jump that made the camera lost.
  /// `placed`: the frame is put at a given pose (never lost; its view is still the next one's
  /// reference). Its code is kept until observe() takes in the same frame: the keyframe that
  /// frame may become, and the view a lost frame's candidates are chosen for, are coded from it,
  /// so no backend makes or returns a small image of its own.
  bool submitted_view(int frame, ImageView<const uint16_t> small_mm, bool placed = false);
  /// Decides the next submitted frame; `frames_in_flight`: attempts already submitted and not
  /// collected make it wait (the pose they reach is not known yet).
  RelocaliserPlan plan();
  /// Takes in a collected frame (in order, each submitted through submitted_view() first); true
  /// when it is the frame the camera was found at. A tracking camera also turns lost at a frame
  /// that tracked after a tracked frame but jumped (frame_jumped()): the accept test passed at
  /// a pose the camera cannot have reached, or with a fit that fell apart, as when frames are
  /// missing and the view turned by more than the fern codes show.
  bool observe(const RelocaliserObservation& frame);

  /// True until a lost camera is found again (integration stops meanwhile).
  bool lost() const { return mode_ != Mode::kTracking; }
  /// Whether collected frame `frame` belongs to the loss: false for frames submitted before a
  /// view jump that made the camera lost (they were tracked and integrated as usual).
  bool lost_at(int frame) const { return lost() && frame >= lost_from_frame_; }
  bool can_relocalise() const { return can_relocalise_; }
  const KeyframeDatabase& keyframes() const { return db_; }
  RelocaliserFigures figures() const;

 private:
  enum class Mode { kTracking, kLost, kVerifying };
  /// A submitted frame's view: its code and its small image (a keyframe keeps both).
  struct SubmittedView {
    int frame = 0;
    std::vector<uint8_t> code;
    HostImage<uint16_t> small_mm;
  };

  /// Whether tracked frame `frame`, collected after the tracked frame last_* describe, moved
  /// the camera more than a frame's plausible motion (verify_max_step_*) or fit the map far
  /// worse than that frame (view_jump_residual_ratio and view_jump_inlier_ratio).
  bool frame_jumped(const RelocaliserObservation& frame) const;
  /// Lost from frame `frame` on, at a view jump: the last good pose is suspect.
  void lose_at_view_jump(int frame, const std::vector<uint8_t>& code);
  void harvest(const RelocaliserObservation& frame, const SubmittedView& view);
  void choose_candidates(const std::vector<uint8_t>& code);

  RelocaliserSettings settings_;
  KeyframeDatabase db_;
  Mode mode_ = Mode::kTracking;
  Mat4f last_good_pose_ = Mat4f::identity();  ///< the owner sets the start pose (trust_pose)
  std::vector<Mat4f> candidates_;             ///< poses to try, best first
  std::vector<int> candidate_ids_;            ///< their keyframes (−1: the last good pose)
  std::vector<int> failed_ids_;               ///< candidates tried since the view last changed
  std::vector<uint8_t> last_view_code_;       ///< the last submitted frame's input-depth code
  /// The views of the frames submitted and not yet observed, oldest first, by frame number.
  std::deque<SubmittedView> submitted_views_;
  Intrinsics small_k_;  ///< zeros until set_small_intrinsics()
  int last_submitted_frame_ = -1;
  /// The last frame not to be integrated while a doubtful frame is in flight
  /// (view_doubt_dissimilarity), −1 for none.
  int hold_to_frame_ = -1;
  int doubt_frame_ = -1;  ///< the doubtful frame itself
  /// The frame observed last (whether it tracked, its pose), the next one's reference for
  /// frame_jumped()'s step; the last good frame's fit (0s before any), the reference for its
  /// fit and for the fits a lost camera's candidates verify with.
  bool last_tracked_ = false;
  Mat4f last_pose_;
  double last_inlier_fraction_ = 0;
  double last_residual_rms_m_ = 0;
  double last_too_far_fraction_ = 0;
  double last_paired_inlier_share_ = 0;  ///< inliers / paired pixels (paired_inlier_share())
  bool view_jumped_ = false;             ///< lost at a view jump: the last good pose is suspect
  int lost_from_frame_ = 0;  ///< the view jump's frame: frames before it are not part of the loss
  /// The last attempt collected was refused (attempt_refused()): the frames tracked on from
  /// its pose until the next attempt is collected verify nothing either.
  bool last_attempt_refused_ = false;
  int pending_attempt_id_ = -2;        ///< the candidate of the last attempt planned
  std::vector<int> attempt_ids_;       ///< the candidates of the attempts in flight, in order
  std::vector<Mat4f> attempt_starts_;  ///< ... and the poses they start from
  int attempts_in_flight_ = 0;
  int lost_frames_ = 0;  ///< lost frames collected since the loss
  int verified_ = 0;     ///< accepted frames in the verification so far
  Mat4f verify_pose_;    ///< the last verified frame's pose
  int attempts_ = 0;
  int relocalisations_ = 0;
  double host_ms_ = 0;
  int alignments_ = 0;
  int aligned_starts_ = 0;
  double max_alignment_ms_ = 0;
  bool can_relocalise_ = true;
};

}  // namespace kfx
