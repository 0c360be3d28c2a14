/// Settings section `input`: its rows and checks.

#include <cmath>

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_input(const PipelineConfig& config) {
  const InputSettings& input = config.input;
  const int r = input.compute_size_ratio;
  KFX_CHECK(r == 1 || r == 2 || r == 4 || r == 8,
            "compute_size_ratio must be 1, 2, 4 or 8, got " << r);
  const auto& k = input.camera_px;
  const bool camera_default = k[0] == 0 && k[1] == 0 && k[2] == 0 && k[3] == 0;
  KFX_CHECK(camera_default || (k[0] != 0 && k[1] != 0),
            "camera: fx and fy must be non-zero, got " << k[0] << "," << k[1]);
  KFX_CHECK(input.depth_scale_per_m >= 0, "depth_scale must be >= 0 (0 = format default)");
  const LensDistortion& lens = input.distortion;
  for (const float c : {lens.k1, lens.k2, lens.p1, lens.p2, lens.k3}) {
    KFX_CHECK(
        std::isfinite(c) && std::fabs(c) <= 100.0f,
        "camera_distortion: each coefficient must be a finite number within +-100, got " << c);
  }
}

}  // namespace

SettingsSection input_section() {
  const std::string s = "input";
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_input;
  auto& rows = section.fields;
  rows.push_back(integer_row(
      "compute_size_ratio", s, "compute size = input size / ratio (1, 2, 4 or 8)",
      [](C& c) -> int& { return c.input.compute_size_ratio; }, {"c", "compute-size-ratio"}));
  rows.push_back(custom_row(
      "camera", s, "intrinsics fx,fy,cx,cy in pixels at input size (default: the format's)",
      [](C& c, const std::string& text) {
        c.input.camera_px = parse_floats<4>("camera", text, false);
      },
      [](const C& c) { return format_list(c.input.camera_px); }, {"k", "camera"}));
  rows.push_back(number_row("depth_scale", s, "PNG depth units per metre (0 = the format's: 5000)",
                            [](C& c) -> double& { return c.input.depth_scale_per_m; }));
  rows.push_back(custom_row(
      "camera_distortion", s,
      "lens distortion k1,k2,p1,p2,k3 (OpenCV's order), used by depth_undistortion (all 0 = "
      "the format's when camera is the format's: TUM fr1, fr2; else none)",
      [](C& c, const std::string& text) {
        const auto k = parse_floats<5>("camera_distortion", text, false);
        c.input.distortion = {k[0], k[1], k[2], k[3], k[4]};
      },
      [](const C& c) {
        const LensDistortion& d = c.input.distortion;
        return format_list(std::array<float, 5>{d.k1, d.k2, d.p1, d.p2, d.k3});
      }));
  return section;
}

}  // namespace kfx::settings
