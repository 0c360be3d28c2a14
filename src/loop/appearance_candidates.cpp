#include "loop/appearance_candidates.hpp"

#include "core/platform.hpp"
#include "localise/keyframe_database.hpp"

namespace kfx::loop {

AppearanceMatcher::AppearanceMatcher(int width_px, int height_px, const AppearanceOptions& options,
                                     int capacity)
    : options_(options),
      database_(width_px, height_px, options.fern_count, capacity),
      last_with_candidates_(-options.keyframe_stride) {}

std::vector<LoopCandidate> AppearanceMatcher::add(ImageView<const uint16_t> small_mm,
                                                  int pose_index) {
  KFX_CHECK(small_mm.width == database_.width_px() && small_mm.height == database_.height_px(),
            "appearance candidates: a small image of " << small_mm.width << "x" << small_mm.height
                                                       << " among ones of " << database_.width_px()
                                                       << "x" << database_.height_px());
  const int j = static_cast<int>(codes_.size());
  codes_.push_back(database_.encode(small_mm));
  poses_.push_back(pose_index);
  while (filed_ < j && pose_index - poses_[filed_] >= options_.min_frame_gap) {
    Keyframe older;
    older.frame = filed_;
    database_.add(codes_[filed_], older);
    ++filed_;
  }
  std::vector<LoopCandidate> out;
  if (database_.empty() || j - last_with_candidates_ < options_.keyframe_stride) return out;
  for (const KeyframeMatch& m :
       database_.nearest(codes_[j], options_.max_candidates_per_keyframe)) {
    if (m.dissimilarity > options_.max_dissimilarity) break;  // nearest first
    out.push_back({database_.keyframe(m.keyframe).frame, j, Pose3d::identity(), "appearance"});
  }
  if (!out.empty()) last_with_candidates_ = j;
  return out;
}

std::vector<LoopCandidate> propose_by_appearance(const std::vector<HostImage<uint16_t>>& small_mm,
                                                 const std::vector<int>& keyframes,
                                                 const AppearanceOptions& options) {
  KFX_CHECK(small_mm.size() == keyframes.size(),
            "propose_by_appearance: " << small_mm.size() << " small images for " << keyframes.size()
                                      << " keyframes");
  std::vector<LoopCandidate> out;
  if (small_mm.empty()) return out;
  AppearanceMatcher matcher(small_mm[0].width(), small_mm[0].height(), options,
                            static_cast<int>(keyframes.size()));
  for (size_t k = 0; k < small_mm.size(); ++k) {
    for (const LoopCandidate& c : matcher.add(small_mm[k].view(), keyframes[k])) out.push_back(c);
  }
  return out;
}

}  // namespace kfx::loop
