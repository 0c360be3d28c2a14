/// Settings section `integration`: its rows and checks.

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_integration(const PipelineConfig& config) {
  const IntegrationSettings& integration = config.integration;
  KFX_CHECK(integration.rate >= 1, "integration_rate must be >= 1, got " << integration.rate);
  KFX_CHECK(integration.holdout >= 0,
            "integration_holdout must be >= 0 (0 = off), got " << integration.holdout);
}

}  // namespace

SettingsSection integration_section() {
  const std::string s = "integration";
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_integration;
  auto& rows = section.fields;
  rows.push_back(integer_row("integration_rate", s, "integrate every N-th tracked frame (>= 1)",
                             [](C& c) -> int& { return c.integration.rate; },
                             {"r", "integration-rate"}));
  rows.push_back(integer_row(
      "integration_holdout", s,
      "evaluation: never integrate frames f >= bootstrap_frames with f % N == 0, so renders "
      "there show the model from views it has not seen (0 = off)",
      [](C& c) -> int& { return c.integration.holdout; }));
  rows.push_back(on_off_row(
      "localise_only", s,
      "track against a loaded map and integrate nothing: the map stays as loaded (on|off; "
      "needs a map loaded before the first frame)",
      [](C& c) -> bool& { return c.integration.localise_only; }));
  return section;
}

}  // namespace kfx::settings
