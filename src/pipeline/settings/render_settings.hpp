#pragma once
/// Settings section `render`: how often the pictures of --renders are made. Rows and checks:
/// render_settings.cpp.

namespace kfx {

/// Section `render` of PipelineConfig.
struct RenderSettings {
  int rate = 4;  ///< render the volume every N frames when rendering is on
};

}  // namespace kfx
