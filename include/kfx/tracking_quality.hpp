#pragma once
/// The tracking state of a frame: how far its pose can be trusted (docs/tracking.md).

namespace kfx {

/// How far a frame's pose can be trusted, judged from the ICP's own evidence.
enum class TrackingQuality : int {
  kGood = 0,  ///< tracked, and the view pins the pose in every direction
  kPoor = 1,  ///< tracked (the accept test passed), but the view lets the pose slide
  kLost = 2,  ///< tracking failed (pose kept), or the camera is not yet located in a loaded map
};

/// "good", "poor" or "lost".
inline const char* tracking_quality_name(TrackingQuality quality) {
  switch (quality) {
    case TrackingQuality::kGood:
      return "good";
    case TrackingQuality::kPoor:
      return "poor";
    case TrackingQuality::kLost:
      return "lost";
  }
  return "?";
}

}  // namespace kfx
