/// Settings section `raycast`: its rows and checks.

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_raycast(const PipelineConfig& config) {
  const RaycastSettings& raycast = config.raycast;
  KFX_CHECK(raycast.near_m > 0 && raycast.far_m > raycast.near_m,
            "raycast planes must satisfy 0 < near_m < far_m, got " << raycast.near_m << ", "
                                                                   << raycast.far_m);
  KFX_CHECK(raycast.large_step_mu > 0, "large_step_mu must be > 0");
}

}  // namespace

SettingsSection raycast_section() {
  const std::string s = "raycast";
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_raycast;
  auto& rows = section.fields;
  rows.push_back(number_row("near_m", s, "raycast near plane, metres",
                            [](C& c) -> float& { return c.raycast.near_m; }));
  rows.push_back(number_row("far_m", s, "raycast far plane, metres",
                            [](C& c) -> float& { return c.raycast.far_m; }));
  rows.push_back(number_row("large_step_mu", s, "raycast large step in units of mu",
                            [](C& c) -> float& { return c.raycast.large_step_mu; }));
  rows.push_back(on_off_row(
      "raycast_tile_bounds", s,
      "volume=blocks: each ray marches only through the depth range that touched blocks cover "
      "in its 8x8-pixel tile (on|off; speed only, the same bits)",
      [](C& c) -> bool& { return c.raycast.tile_bounds; }));
  return section;
}

}  // namespace kfx::settings
