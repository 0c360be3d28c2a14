#pragma once
/// Aligns a lost view to a keyframe on the host, before a relocalisation attempt is spent on
/// the keyframe: a small rigid alignment between the two small depth images
/// (kernels/small_depth.hpp), so that the attempt starts at the keyframe's pose moved by the
/// camera's motion from it rather than at the keyframe's pose itself. The keyframes nearest a
/// lost view by fern code are often 20–50 cm or 20–40° from the camera, beyond the map ICP's
/// reach from the keyframe's own pose (bench/RESULTS.md, "Where issues 41, 42, 43 and 47 stand
/// after Session 27"); two views that look alike overlap, and the overlap says how they differ.
///
/// Projective point-to-plane ICP of the view's back-projected small pixels against the
/// keyframe's, started from a handful of turned poses (the views differ mostly by a turn at
/// this size), keeping the start whose end fits best. About 1 200 pixels a side: well under a
/// millisecond a start on one core.

#include <cstdint>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "kernels/small_depth.hpp"

namespace kfx {

/// The small image's intrinsics: each small pixel is the mean of a factor × factor block of
/// the compute-size image, so its centre lies at the block's centre in compute pixels.
Intrinsics small_depth_intrinsics(const Intrinsics& compute_k, const SmallDepthParams& p);

/// What aligning a view to a keyframe found.
struct SmallDepthAlignment {
  /// The view's camera in the keyframe camera's frame (x_keyframe = T · x_view).
  Mat4f T_keyframe_view = Mat4f::identity();
  /// Share of the view's valid small pixels paired with a keyframe pixel within the final
  /// distance gate and with agreeing normals at the end; 0 when nothing could be paired.
  float inlier_fraction = 0;
  /// Point-to-plane RMS of those pairs, metres.
  float rms_m = 0;
  /// Valid small pixels of the view (a depth and a normal).
  int view_points = 0;
};

/// Aligns the view `view_mm` to the keyframe `keyframe_mm` (small images of the same size, mm,
/// 0 for none), both seen through `small_k`.
SmallDepthAlignment align_small_depth(ImageView<const uint16_t> view_mm,
                                      ImageView<const uint16_t> keyframe_mm,
                                      const Intrinsics& small_k);

}  // namespace kfx
