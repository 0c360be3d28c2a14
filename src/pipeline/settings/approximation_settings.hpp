#pragma once
/// Settings section `approximations`: the seed thesis's techniques and more, each defaulting
/// to exact (docs/algorithm.md §5). Rows and checks: approximation_settings.cpp.

#include <array>

#include "kernels/integrate.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/raycast.hpp"

namespace kfx {

/// Section `approximations` of PipelineConfig. `kfx settings` lists each with its effect and
/// range.
struct ApproximationSettings {
  BilateralMode bilateral_mode = BilateralMode::kExact;  ///< exact (5×5 with range) | spatial3x3
  bool zero_padded_depth = false;                        ///< bilateral reads outside the image as 0
  int icp_stride_px = 1;         ///< track one pixel per s × s block, weighted s²
  int integration_z_stride = 1;  ///< integrate 1 voxel in s, rotating per frame
  IntegrationPattern integration_pattern = IntegrationPattern::kSlices;  ///< slices | checker
  RayFactor ray_factor = RayFactor::kExact;                              ///< exact | approx | none
  bool integrate_zero_depth_test = true;      ///< skip pixels without depth when integrating
  int raycast_rate = 1;                       ///< raycast every N-th frame (ICP reuses the last)
  std::array<int, 2> raycast_block_px{1, 1};  ///< one ray per bx × by block, copied into it
  float raycast_constant_step_m = 0.0f;       ///< > 0: constant march step (no fine steps)
  RaycastStep raycast_step = RaycastStep::kKFusion;  ///< kfusion (a voxel in the band) | tsdf
  float raycast_tsdf_step_factor =
      0.5f;  ///< raycast_step=tsdf: step factor · tsdf · mu in the band
  RaycastInterp raycast_interp = RaycastInterp::kTrilinear;    ///< trilinear | two_value
  RaycastNormals raycast_normals = RaycastNormals::kGradient;  ///< gradient | neighbours
};

}  // namespace kfx
