#include "loop/appearance_candidates.hpp"

#include "core/platform.hpp"
#include "localise/keyframe_database.hpp"

namespace kfx::loop {

std::vector<LoopCandidate> propose_by_appearance(const std::vector<HostImage<uint16_t>>& small_mm,
                                                 const std::vector<int>& keyframes,
                                                 const AppearanceOptions& options) {
  KFX_CHECK(small_mm.size() == keyframes.size(),
            "propose_by_appearance: " << small_mm.size() << " small images for " << keyframes.size()
                                      << " keyframes");
  std::vector<LoopCandidate> out;
  if (small_mm.empty()) return out;
  const int count = static_cast<int>(keyframes.size());
  KeyframeDatabase database(small_mm[0].width(), small_mm[0].height(), options.fern_count, count);
  std::vector<std::vector<uint8_t>> codes;
  codes.reserve(small_mm.size());
  for (const HostImage<uint16_t>& image : small_mm) {
    KFX_CHECK(image.width() == database.width_px() && image.height() == database.height_px(),
              "propose_by_appearance: small images of different sizes");
    codes.push_back(database.encode(image.view()));
  }
  int filed = 0;  // keyframes in the database: those old enough for the current one
  int last_with_candidates = -options.keyframe_stride;
  for (int j = 0; j < count; ++j) {
    while (filed < j && keyframes[j] - keyframes[filed] >= options.min_frame_gap) {
      Keyframe older;
      older.frame = filed;
      database.add(codes[filed], older);
      ++filed;
    }
    if (database.empty() || j - last_with_candidates < options.keyframe_stride) continue;
    bool any = false;
    for (const KeyframeMatch& m : database.nearest(codes[j], options.max_candidates_per_keyframe)) {
      if (m.dissimilarity > options.max_dissimilarity) break;  // nearest first
      out.push_back({database.keyframe(m.keyframe).frame, j, Pose3d::identity(), "appearance"});
      any = true;
    }
    if (any) last_with_candidates = j;
  }
  return out;
}

}  // namespace kfx::loop
