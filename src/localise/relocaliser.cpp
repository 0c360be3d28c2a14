#include "localise/relocaliser.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/platform.hpp"
#include "localise/located_pose.hpp"
#include "localise/small_depth_alignment.hpp"

namespace kfx {
namespace {

/// Lost frames during which the last good pose is tried first: a short loss (a fast turn, a
/// blurred frame) usually leaves the camera near where it was; a long one, not.
constexpr int kLastPoseFirstFrames = 3;

/// Whether `frame`'s fit fell apart against a good frame's (inlier fraction `inliers`, residual
/// RMS `rms_m`): its residual grew past, and its inliers fell below, the settings' ratios. No
/// good frame yet (0s): never.
bool fit_fell_apart(const RelocaliserSettings& s, const RelocaliserObservation& frame,
                    double inliers, double rms_m) {
  return frame.residual_rms_m > s.view_jump_residual_ratio * rms_m &&
         frame.inlier_fraction < s.view_jump_inlier_ratio * inliers;
}

/// The share of a frame's pixels paired with a map point that are inliers: how well the pixels
/// the map covers fit, whatever share of the view the map covers.
double paired_inlier_share(const RelocaliserObservation& frame) {
  const double paired = frame.inlier_fraction + frame.too_far_fraction + frame.bad_normal_fraction;
  return paired > 0 ? frame.inlier_fraction / paired : 0.0;
}

/// Whether an attempt's pose is refused before any verification: its ICP ended farther than
/// candidate_reach_m from the candidate it started at, or left a residual RMS past
/// view_jump_residual_ratio times the last good frame's `rms_m`, or a paired inlier share
/// below view_jump_inlier_ratio times that frame's `paired_share`. A frame tracked on from a
/// good pose may fit worse for a while (a fast turn); a candidate that fits so is a wrong
/// minimum more often than not, and taking one fuses a view at the wrong place. Measured
/// (bench/RESULTS.md, "Attempts that end far from their candidate"): right attempts on the cut
/// real sequences left 0.8–1.7 times the last good residual, a false one on icl_office_kt0 5.9
/// times. Its inliers are weighed over the pixels the map covers from the candidate
/// (paired_inlier_share), not over the view: a camera found again where the map covers part of
/// its view pairs only that part, and its inliers over the whole view fall short of the last
/// good frame's though each paired pixel fits (bench/RESULTS.md, "Attempts over part of the
/// map").
bool attempt_refused(const RelocaliserSettings& s, const RelocaliserObservation& frame,
                     const Mat4f& candidate, double paired_share, double rms_m) {
  float metres = 0, degrees = 0;
  pose_difference(candidate, frame.T_world_cam, metres, degrees);
  return metres > s.candidate_reach_m ||
         (rms_m > 0 && (frame.residual_rms_m > s.view_jump_residual_ratio * rms_m ||
                        paired_inlier_share(frame) < s.view_jump_inlier_ratio * paired_share));
}

/// Whether a frame of a lost camera's attempt or verification disagrees with the map: more of
/// its pixels paired too far away than the floor and the ratio to the last good frame's
/// `too_far` allow (RelocaliserSettings::candidate_too_far_*). No good frame yet (`rms_m` 0, a
/// loaded map): never, as the share a good fit leaves differs from scene to scene (0.002 on
/// icl_office_kt0, 0.02–0.04 on the noisy synthetic room).
bool disagrees_with_map(const RelocaliserSettings& s, const RelocaliserObservation& frame,
                        double too_far, double rms_m) {
  return rms_m > 0 &&
         frame.too_far_fraction >
             std::max<double>(s.candidate_too_far_floor, s.candidate_too_far_ratio * too_far);
}

}  // namespace

Relocaliser::Relocaliser(const RelocaliserSettings& settings, int small_width_px,
                         int small_height_px)
    : settings_(settings),
      db_(small_width_px, small_height_px, settings.fern_count, settings.keyframe_capacity) {}

void Relocaliser::reset() {
  db_.clear();
  mode_ = Mode::kTracking;
  candidates_.clear();
  candidate_ids_.clear();
  failed_ids_.clear();
  last_view_code_.clear();
  submitted_views_.clear();
  last_submitted_frame_ = -1;
  hold_to_frame_ = -1;
  doubt_frame_ = -1;
  last_tracked_ = false;
  last_inlier_fraction_ = 0;
  last_residual_rms_m_ = 0;
  last_too_far_fraction_ = 0;
  last_paired_inlier_share_ = 0;
  view_jumped_ = false;
  lost_from_frame_ = 0;
  attempt_ids_.clear();
  attempt_starts_.clear();
  last_attempt_refused_ = false;
  pending_attempt_id_ = -2;
  attempts_in_flight_ = 0;
  lost_frames_ = 0;
  verified_ = 0;
  attempts_ = 0;
  relocalisations_ = 0;
  host_ms_ = 0;
  alignments_ = 0;
  aligned_starts_ = 0;
  max_alignment_ms_ = 0;
  can_relocalise_ = true;
}

Mat4f Relocaliser::candidate_pose(int keyframe, ImageView<const uint16_t> small_mm) {
  const Mat4f& raw = db_.keyframe(keyframe).T_world_cam;
  const ImageView<const uint16_t> image = db_.image(keyframe);
  if (!settings_.align_candidates || image.data == nullptr || small_mm.data == nullptr ||
      !(small_k_.fx != 0.0f)) {
    return raw;
  }
  const auto start = std::chrono::steady_clock::now();
  const SmallDepthAlignment a = align_small_depth(small_mm, image, small_k_);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  host_ms_ += ms;
  max_alignment_ms_ = std::max(max_alignment_ms_, ms);
  ++alignments_;
  if (a.inlier_fraction < settings_.align_min_inliers ||
      length(a.T_keyframe_view.translation_part()) > settings_.candidate_reach_m) {
    return raw;
  }
  ++aligned_starts_;
  return raw * a.T_keyframe_view;
}

void Relocaliser::trust_pose(const Mat4f& T_world_cam) {
  // The camera was put elsewhere on purpose: the next view is no jump.
  last_view_code_.clear();
  last_tracked_ = false;
  mode_ = Mode::kTracking;
  last_good_pose_ = T_world_cam;
  candidates_.clear();
  candidate_ids_.clear();
  failed_ids_.clear();
  verified_ = 0;
  last_attempt_refused_ = false;
}

void Relocaliser::adopt_keyframes(std::optional<KeyframeDatabase> keyframes) {
  can_relocalise_ = false;
  db_.clear();
  if (keyframes && keyframes->width_px() == db_.width_px() &&
      keyframes->height_px() == db_.height_px() && keyframes->fern_count() == db_.fern_count() &&
      keyframes->tests().size() == db_.tests().size()) {
    // The saved database keeps its ferns (its codes were made with them), with room as set here.
    const int capacity = db_.capacity();
    db_ = std::move(*keyframes);
    db_.set_capacity(capacity);
    can_relocalise_ = true;
  }
}

void Relocaliser::start_lost(const Mat4f& T_world_cam) {
  last_view_code_.clear();
  last_tracked_ = false;
  view_jumped_ = false;
  mode_ = Mode::kLost;
  last_good_pose_ = T_world_cam;
  candidates_.assign(1, T_world_cam);
  candidate_ids_.assign(1, -1);
  failed_ids_.clear();
  lost_frames_ = 0;
  verified_ = 0;
  lost_from_frame_ = 0;
  last_attempt_refused_ = false;
}

bool Relocaliser::submitted_view(int frame, ImageView<const uint16_t> small_mm, bool placed) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<uint8_t> code = db_.encode(small_mm);
  bool view_jump = false, doubtful = false;
  if (last_view_code_.size() == code.size()) {
    int differ = 0;
    for (size_t i = 0; i < code.size(); ++i) differ += code[i] != last_view_code_[i];
    doubtful = differ > settings_.view_doubt_dissimilarity * static_cast<float>(code.size());
    view_jump = differ > settings_.view_jump_dissimilarity * static_cast<float>(code.size());
  }
  // Only a tracking camera turns lost here: a lost or verifying one tries candidates anyway.
  const bool lost_now = view_jump && !placed && mode_ == Mode::kTracking;
  if (lost_now) {
    // The frames before this one, still in flight, were tracked and integrated as usual and are
    // collected as such.
    lose_at_view_jump(frame, code);
  } else if (doubtful && !placed && mode_ == Mode::kTracking) {
    // Not integrated until its tracking is seen; the next frame is submitted before that.
    doubt_frame_ = frame;
    hold_to_frame_ = frame + 1;
  }
  last_submitted_frame_ = frame;
  SubmittedView& view = submitted_views_.emplace_back();
  view.frame = frame;
  view.code = code;
  view.small_mm = copy_of(small_mm);
  last_view_code_ = std::move(code);
  host_ms_ +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return lost_now;
}

RelocaliserPlan Relocaliser::plan() {
  RelocaliserPlan p;
  p.integrate = mode_ == Mode::kTracking && last_submitted_frame_ > hold_to_frame_;
  if (mode_ != Mode::kLost || attempts_in_flight_ > 0 || candidates_.empty()) return p;
  // The best candidate not tried since the view last changed; all tried: start the round again.
  size_t pick = candidates_.size();
  for (size_t i = 0; i < candidates_.size() && pick == candidates_.size(); ++i) {
    if (std::find(failed_ids_.begin(), failed_ids_.end(), candidate_ids_[i]) == failed_ids_.end()) {
      pick = i;
    }
  }
  if (pick == candidates_.size()) {
    failed_ids_.clear();
    pick = 0;
  }
  p.attempt = true;
  p.T_world_cam = candidates_[pick];
  // A keyframe's candidate is aligned to the frame the attempt is made on: the frame just
  // submitted (submitted_view()).
  if (candidate_ids_[pick] >= 0 && !submitted_views_.empty() &&
      submitted_views_.back().frame == last_submitted_frame_) {
    p.T_world_cam = candidate_pose(candidate_ids_[pick], submitted_views_.back().small_mm.view());
  }
  pending_attempt_id_ = candidate_ids_[pick];
  attempt_ids_.push_back(pending_attempt_id_);
  attempt_starts_.push_back(p.T_world_cam);
  failed_ids_.push_back(pending_attempt_id_);
  ++attempts_in_flight_;
  return p;
}

bool Relocaliser::observe(const RelocaliserObservation& frame) {
  const auto start = std::chrono::steady_clock::now();
  int attempt_id = -2;
  bool refused = false;
  if (frame.attempt) {
    --attempts_in_flight_;
    ++attempts_;
    if (!attempt_ids_.empty()) {
      attempt_id = attempt_ids_.front();
      attempt_ids_.erase(attempt_ids_.begin());
      refused = attempt_refused(settings_, frame, attempt_starts_.front(),
                                last_paired_inlier_share_, last_residual_rms_m_);
      attempt_starts_.erase(attempt_starts_.begin());
    }
    last_attempt_refused_ = refused;
  }
  // The frame's view from submitted_view(); frames observed out of turn leave theirs behind.
  SubmittedView view;
  while (!submitted_views_.empty() && submitted_views_.front().frame < frame.frame) {
    submitted_views_.pop_front();
  }
  if (!submitted_views_.empty() && submitted_views_.front().frame == frame.frame) {
    view = std::move(submitted_views_.front());
    submitted_views_.pop_front();
  }
  const std::vector<uint8_t>& code = view.code;
  bool found = false;
  // A frame submitted before the view jump that made the camera lost: it tracked (or not) in
  // the old view, and the loss's candidates belong to the new one.
  const bool before_jump = mode_ == Mode::kLost && view_jumped_ && frame.frame < lost_from_frame_;
  switch (before_jump ? Mode::kTracking : mode_) {
    case Mode::kTracking:
      if (before_jump) {
        if (frame.tracked && frame.good && !code.empty()) harvest(frame, view);
      } else if (frame.tracked && !frame.attempt && frame_jumped(frame)) {
        // Tracked from the old pose into a view it does not belong to: the frames behind it,
        // in flight, were tracked on from its pose and belong to the loss too.
        lose_at_view_jump(frame.frame, code);
      } else if (frame.tracking_ran && !frame.tracked) {
        mode_ = Mode::kLost;
        lost_from_frame_ = frame.frame;
        lost_frames_ = 1;
        failed_ids_.clear();
        if (!code.empty()) choose_candidates(code);
      } else if (frame.tracked && frame.good) {
        last_good_pose_ = frame.T_world_cam;
        if (!code.empty()) harvest(frame, view);
      }
      break;
    case Mode::kLost: {
      // After a view jump only an attempt from a keyframe starts a verification: frames that
      // track on from the suspect pose would verify it; nor do frames tracked on from an
      // attempt refused (attempt_refused()). The accept test passes fits far worse than
      // tracking makes (a residual five times the last good frame's at a pose 10–20 cm off,
      // bench/RESULTS.md "The view jump the ICP sees"), and fits that pair much of the view
      // with map points far away (disagrees_with_map()): such fits verify nothing.
      const bool may_verify = frame.attempt ? !refused && (!view_jumped_ || attempt_id >= 0)
                                            : !view_jumped_ && !last_attempt_refused_;
      if (frame.tracked && may_verify &&
          !fit_fell_apart(settings_, frame, last_inlier_fraction_, last_residual_rms_m_) &&
          !disagrees_with_map(settings_, frame, last_too_far_fraction_, last_residual_rms_m_)) {
        mode_ = Mode::kVerifying;
        verified_ = 1;
        verify_pose_ = frame.T_world_cam;
      } else {
        ++lost_frames_;
        if (!code.empty()) choose_candidates(code);
      }
      break;
    }
    case Mode::kVerifying: {
      float metres = 0, degrees = 0;
      if (frame.tracked) pose_difference(verify_pose_, frame.T_world_cam, metres, degrees);
      if (!frame.tracked || metres > settings_.verify_max_step_m ||
          degrees > settings_.verify_max_step_deg ||
          fit_fell_apart(settings_, frame, last_inlier_fraction_, last_residual_rms_m_) ||
          disagrees_with_map(settings_, frame, last_too_far_fraction_, last_residual_rms_m_)) {
        mode_ = Mode::kLost;
        ++lost_frames_;
        if (!code.empty()) choose_candidates(code);
        break;
      }
      verify_pose_ = frame.T_world_cam;
      if (++verified_ >= settings_.verify_frames) {
        mode_ = Mode::kTracking;
        view_jumped_ = false;
        ++relocalisations_;
        found = true;
        last_good_pose_ = frame.T_world_cam;
        failed_ids_.clear();
      }
      break;
    }
  }
  // A doubtful frame that did not jump releases the frames held behind it (those not yet
  // submitted; one already submitted stays unintegrated).
  if (frame.frame == doubt_frame_ && mode_ == Mode::kTracking) hold_to_frame_ = frame.frame;
  last_tracked_ = frame.tracking_ran && frame.tracked;
  last_pose_ = frame.T_world_cam;
  // The fit a good frame makes: what a jump's or a candidate's fit is measured against.
  if (mode_ == Mode::kTracking && last_tracked_ && frame.good) {
    last_inlier_fraction_ = frame.inlier_fraction;
    last_residual_rms_m_ = frame.residual_rms_m;
    last_too_far_fraction_ = frame.too_far_fraction;
    last_paired_inlier_share_ = paired_inlier_share(frame);
  }
  host_ms_ +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return found;
}

bool Relocaliser::frame_jumped(const RelocaliserObservation& frame) const {
  if (!last_tracked_ || !frame.tracking_ran || !frame.tracked) return false;
  float metres = 0, degrees = 0;
  pose_difference(last_pose_, frame.T_world_cam, metres, degrees);
  if (metres > settings_.verify_max_step_m || degrees > settings_.verify_max_step_deg) return true;
  return fit_fell_apart(settings_, frame, last_inlier_fraction_, last_residual_rms_m_);
}

void Relocaliser::lose_at_view_jump(int frame, const std::vector<uint8_t>& code) {
  // The last good pose is where the camera no longer is: only keyframes that look like the new
  // view are candidates.
  mode_ = Mode::kLost;
  view_jumped_ = true;
  lost_from_frame_ = frame;
  lost_frames_ = kLastPoseFirstFrames + 1;
  failed_ids_.clear();
  if (!code.empty()) choose_candidates(code);
}

void Relocaliser::harvest(const RelocaliserObservation& frame, const SubmittedView& view) {
  if (db_.full()) return;
  const std::vector<KeyframeMatch> nearest = db_.nearest(view.code, 1);
  if (nearest.empty() || nearest[0].dissimilarity > settings_.harvest_dissimilarity) {
    db_.add(view.code, Keyframe{frame.T_world_cam, frame.frame}, view.small_mm.view());
  }
}

void Relocaliser::choose_candidates(const std::vector<uint8_t>& code) {
  const std::vector<KeyframeMatch> nearest = db_.nearest(code, settings_.candidates);
  std::vector<Mat4f> poses;
  std::vector<int> ids;
  const bool last_first = lost_frames_ <= kLastPoseFirstFrames && !view_jumped_;
  if (last_first) {
    poses.push_back(last_good_pose_);
    ids.push_back(-1);
  }
  for (const KeyframeMatch& m : nearest) {
    poses.push_back(db_.keyframe(m.keyframe).T_world_cam);
    ids.push_back(m.keyframe);
  }
  // Without keyframes to try, a view jump leaves only the last good pose (and tracking on).
  if (view_jumped_ && poses.empty()) view_jumped_ = false;
  if (!last_first && !view_jumped_) {
    poses.push_back(last_good_pose_);
    ids.push_back(-1);
  }
  // A candidate that left the list and comes back belongs to a new view: it gets a new try.
  failed_ids_.erase(
      std::remove_if(failed_ids_.begin(), failed_ids_.end(),
                     [&](int id) { return std::find(ids.begin(), ids.end(), id) == ids.end(); }),
      failed_ids_.end());
  candidates_ = std::move(poses);
  candidate_ids_ = std::move(ids);
}

RelocaliserFigures Relocaliser::figures() const {
  RelocaliserFigures f;
  f.keyframes = db_.size();
  f.attempts = attempts_;
  f.relocalisations = relocalisations_;
  f.memory_bytes = db_.memory_bytes();
  f.capacity_bytes = db_.capacity_bytes();
  f.host_ms = host_ms_;
  f.alignments = alignments_;
  f.aligned_starts = aligned_starts_;
  f.max_alignment_ms = max_alignment_ms_;
  f.can_relocalise = can_relocalise_;
  return f;
}

}  // namespace kfx
