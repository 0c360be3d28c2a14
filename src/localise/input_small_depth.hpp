#pragma once
/// The small depth image of a frame made on the host from its input depth, before the frame is
/// submitted: the one view code relocalisation uses (localise/relocaliser.hpp). So the view-jump
/// test can decide, before anything of the frame is integrated, that the camera jumped (frames
/// missing from the input, the camera moved while covered), and keyframes are harvested and
/// looked up by the same code with nothing made on or copied back from the device: a small
/// image made there from the filtered depth cost the GPU frame 5–7 % (bench/RESULTS.md,
/// "Session 24"), and would be known only once the frame is fused.
/// Same kernel bodies (kernels/small_depth.hpp) on the input depth sampled at the compute size
/// without the bilateral filter: a view signature, compared only with other frames' made the
/// same way (a map's saved keyframes included).

#include <cstdint>

#include "core/image.hpp"
#include "kernels/small_depth.hpp"

namespace kfx {

class InputSmallDepth {
 public:
  InputSmallDepth() = default;
  /// For input frames `compute_ratio` times the compute size, small images of `p`'s size.
  InputSmallDepth(const SmallDepthParams& p, int compute_ratio);

  /// The small image of `depth_mm` (input size, millimetres, 0 for none); valid until the
  /// next call.
  ImageView<const uint16_t> make(ImageView<const uint16_t> depth_mm);
  /// The same small image in an image of its own, for callers that keep several (offline
  /// loop candidates code every keyframe's at once).
  HostImage<uint16_t> make_copy(ImageView<const uint16_t> depth_mm);

 private:
  SmallDepthParams p_;
  int ratio_ = 1;
  HostImage<float> compute_m_;  ///< the input sampled at the compute size, metres
  HostImage<uint16_t> mean_mm_;
  HostImage<uint16_t> small_mm_;
};

}  // namespace kfx
