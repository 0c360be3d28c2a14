#pragma once
/// Undistorting the depth image (setting depth_undistortion): KFusion treats the camera as a
/// pinhole, but a Kinect's depth registered to its colour camera (TUM fr1, fr2) carries that
/// lens's distortion, up to 7 % of the radius at the corners. The table built here tells the
/// mm → m step which input pixel each compute pixel of the ideal pinhole image reads
/// (nearest, so no depth is blended across an edge); every later stage stays a pinhole one.

#include "core/camera.hpp"
#include "core/image.hpp"
#include "kernels/preprocess.hpp"

namespace kfx {

/// For compute pixel (x, y), the ideal (pinhole) input pixel (x·ratio, y·ratio) is moved
/// through `distortion` with `input_k` and rounded to the nearest input pixel of an
/// input_width_px × input_height_px image; x = −1 where that falls outside it. With no
/// distortion every entry is (x·ratio, y·ratio), KFusion's subsampling.
HostImage<SourcePixel> depth_source_table(const Intrinsics& input_k,
                                          const LensDistortion& distortion, int input_width_px,
                                          int input_height_px, int ratio);

}  // namespace kfx
