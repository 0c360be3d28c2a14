#pragma once
/// Loop candidates by appearance: keyframes whose small depth images get nearly the same
/// random-fern code (the relocaliser's keyframe database, localise/keyframe_database.hpp) are
/// taken to see the same place, wherever the odometry puts them. This finds the revisits that
/// drift hides from proximity (a building's loop returns with its error of decimetres); the
/// geometric verification then decides (loop/loop_verifier.hpp), and a place that only looks
/// the same (two identical rooms) is rejected there or switched off by the pose graph.

#include <cstdint>
#include <vector>

#include "core/image.hpp"
#include "localise/keyframe_database.hpp"
#include "loop/loop_candidates.hpp"

namespace kfx::loop {

/// What makes two keyframes a candidate by their views.
struct AppearanceOptions {
  /// Codes differing in at most this share of the ferns (0–1). Consecutive frames of a slow
  /// camera differ in 0.02–0.13 and the relocaliser treats 0.4 as a different view; 0.2 kept
  /// only the weakest views of the synthetic room's loop, 0.3 its verifiable ones.
  float max_dissimilarity = 0.3f;
  int fern_count = 500;     ///< ferns of the code (the relocaliser's default)
  int min_frame_gap = 200;  ///< at least this many poses apart in time
  int max_candidates_per_keyframe =
      2;  ///< the most alike older keyframes a keyframe is paired with
  /// A keyframe less than this many keyframes after the last one given candidates gets none:
  /// a revisit spans many keyframes, and each loop costs a verification. Lower than
  /// proximity's: a view that looks alike may still be too weak a view to verify (a plain
  /// wall), and its neighbour is the next chance.
  int keyframe_stride = 2;
};

/// The same pairing one keyframe at a time, for a run that keeps keyframes as it goes (the
/// online closure): each keyframe is coded as it comes and filed for later ones once a newer
/// keyframe is min_frame_gap poses after it.
class AppearanceMatcher {
 public:
  /// For small images of width × height pixels; room for `capacity` filed keyframes.
  AppearanceMatcher(int width_px, int height_px, const AppearanceOptions& options, int capacity);
  /// The next keyframe (index: the count added before it), taken at pose index `pose_index`
  /// (increasing), and its small image: the candidates pairing it with older keyframes.
  std::vector<LoopCandidate> add(ImageView<const uint16_t> small_mm, int pose_index);

 private:
  AppearanceOptions options_;
  KeyframeDatabase database_;
  std::vector<std::vector<uint8_t>> codes_;
  std::vector<int> poses_;
  int filed_ = 0;  ///< keyframes in the database: those old enough for the latest one
  int last_with_candidates_;
};

/// Candidates from the keyframes' views alone. `small_mm[k]` is keyframe k's small depth image
/// (kernels/small_depth.hpp; all the same size), `keyframes[k]` its pose index (in order). Each
/// candidate's guess is the identity: a view that looks the same was taken from about the same
/// pose as the older one.
std::vector<LoopCandidate> propose_by_appearance(const std::vector<HostImage<uint16_t>>& small_mm,
                                                 const std::vector<int>& keyframes,
                                                 const AppearanceOptions& options = {});

}  // namespace kfx::loop
