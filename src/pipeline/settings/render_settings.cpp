/// Settings section `render`: its rows and checks.

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_render(const PipelineConfig& config) {
  KFX_CHECK(config.render.rate >= 1, "render_rate must be >= 1, got " << config.render.rate);
}

}  // namespace

SettingsSection render_section() {
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_render;
  section.fields.push_back(integer_row("render_rate", "render", "render every N-th frame (>= 1)",
                                       [](C& c) -> int& { return c.render.rate; },
                                       {"z", "rendering-rate"}));
  return section;
}

}  // namespace kfx::settings
