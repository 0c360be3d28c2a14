#pragma once
/// Settings section `integration`: which frames are fused into the map. Rows and checks:
/// integration_settings.cpp.

namespace kfx {

/// Section `integration` of PipelineConfig.
struct IntegrationSettings {
  int rate = 2;  ///< integrate tracked frames f with f % rate == 0 (and frames 0–3)
  /// Evaluation: frames f ≥ bootstrap with f % holdout == 0 are tracked but never integrated,
  /// so the model can be compared with frames it has not seen (0 = none held out).
  int holdout = 0;
  /// Localisation only: track against a loaded map and integrate nothing (the map stays as
  /// loaded; a robot that maps once and then navigates). Needs a loaded map.
  bool localise_only = false;
};

}  // namespace kfx
