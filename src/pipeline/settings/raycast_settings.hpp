#pragma once
/// Settings section `raycast`: the march that renders the model for the next frame's ICP. Rows
/// and checks: raycast_settings.cpp.

namespace kfx {

/// Section `raycast` of PipelineConfig.
struct RaycastSettings {
  float near_m = 0.4f;          ///< near plane
  float far_m = 4.0f;           ///< far plane
  float large_step_mu = 0.75f;  ///< large march step, in units of mu
  /// Blocks: march each ray only through its tile's touched depth range (speed only).
  bool tile_bounds = true;
};

}  // namespace kfx
