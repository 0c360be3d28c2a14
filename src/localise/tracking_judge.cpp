#include "localise/tracking_judge.hpp"

namespace kfx {

void TrackingJudge::restart(bool starts_lost) {
  state_ = starts_lost ? TrackingQuality::kLost : TrackingQuality::kGood;
  weak_run_ = 0;
  strong_run_ = 0;
}

TrackingQuality TrackingJudge::judge(const TrackingEvidence& e) {
  if (!e.tracking_ran) return state_;
  if (!e.tracked) {
    weak_run_ = 0;
    strong_run_ = 0;
    state_ = TrackingQuality::kLost;
    return state_;
  }
  const bool weak = e.constraint_min < kWeakConstraint;
  weak_run_ = weak ? weak_run_ + 1 : 0;
  strong_run_ = weak ? 0 : strong_run_ + 1;
  if (weak_run_ >= kWeakFramesToPoor) {
    state_ = TrackingQuality::kPoor;
  } else if (state_ == TrackingQuality::kLost) {
    // Re-acquired: the accept test passed against the map again.
    state_ = TrackingQuality::kGood;
  } else if (state_ == TrackingQuality::kPoor && strong_run_ >= kStrongFramesToGood) {
    state_ = TrackingQuality::kGood;
  }
  return state_;
}

void TrackingTimeline::add(int frame, TrackingQuality quality) {
  ++counts_[static_cast<int>(quality)];
  if (quality == TrackingQuality::kGood) {
    open_ = false;
    return;
  }
  if (open_ && stretches_.back().quality == quality) {
    stretches_.back().last_frame = frame;
    ++stretches_.back().frames;
    return;
  }
  stretches_.push_back(TrackingStretch{quality, frame, frame, 1});
  open_ = true;
}

}  // namespace kfx
