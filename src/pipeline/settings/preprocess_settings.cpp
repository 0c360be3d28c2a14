/// Settings section `preprocess`: its rows and checks.

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_preprocess(const PipelineConfig& config) {
  const PreprocessSettings& preprocess = config.preprocess;
  KFX_CHECK(preprocess.bilateral_radius_px >= 0 && preprocess.bilateral_radius_px <= 4,
            "bilateral_radius_px must be in 0..4, got " << preprocess.bilateral_radius_px);
  KFX_CHECK(preprocess.bilateral_spatial_sigma_px > 0, "bilateral_spatial_sigma_px must be > 0");
  KFX_CHECK(preprocess.bilateral_range_sigma_m > 0, "bilateral_range_sigma_m must be > 0");
}

}  // namespace

SettingsSection preprocess_section() {
  const std::string s = "preprocess";
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_preprocess;
  auto& rows = section.fields;
  rows.push_back(integer_row("bilateral_radius_px", s, "bilateral window radius (0..4)",
                             [](C& c) -> int& { return c.preprocess.bilateral_radius_px; }));
  rows.push_back(
      number_row("bilateral_spatial_sigma_px", s, "bilateral spatial sigma, pixels",
                 [](C& c) -> float& { return c.preprocess.bilateral_spatial_sigma_px; }));
  rows.push_back(number_row("bilateral_range_sigma_m", s, "bilateral range sigma, metres",
                            [](C& c) -> float& { return c.preprocess.bilateral_range_sigma_m; }));
  return section;
}

}  // namespace kfx::settings
