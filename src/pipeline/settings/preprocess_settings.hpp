#pragma once
/// Settings section `preprocess`: the bilateral filter of the depth that tracking sees. Rows
/// and checks: preprocess_settings.cpp.

namespace kfx {

/// Section `preprocess` of PipelineConfig.
struct PreprocessSettings {
  int bilateral_radius_px = 2;              ///< window (2r+1)²
  float bilateral_spatial_sigma_px = 4.0f;  ///< Gaussian σ of the spatial weight
  float bilateral_range_sigma_m = 0.1f;     ///< σ of the range weight
};

}  // namespace kfx
