/// Settings section `colour`: its rows and checks.

#include <cmath>

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_colour(const PipelineConfig& config) {
  const auto& ck = config.colour.camera_px;
  KFX_CHECK((ck[0] == 0 && ck[1] == 0 && ck[2] == 0 && ck[3] == 0) || (ck[0] != 0 && ck[1] != 0),
            "colour_camera: fx and fy must be non-zero, got " << ck[0] << "," << ck[1]);
  for (float e : config.colour.extrinsic) {
    KFX_CHECK(std::isfinite(e) && std::fabs(e) <= 10.0f,
              "colour_extrinsic: each entry must be a finite number within +-10, got " << e);
  }
}

}  // namespace

SettingsSection colour_section() {
  const std::string s = "colour";
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_colour;
  auto& rows = section.fields;
  rows.push_back(on_off_row(
      "colour", s,
      "fuse the input's colour beside the TSDF: coloured mesh, cloud and renders (on|off; kfx "
      "turns it on when the input has colour; never changes the trajectory)",
      [](C& c) -> bool& { return c.colour.fuse; }));
  rows.push_back(custom_row(
      "colour_camera", s,
      "colour camera fx,fy,cx,cy in pixels of the colour image (all 0 = the depth camera's)",
      [](C& c, const std::string& text) {
        c.colour.camera_px = parse_floats<4>("colour_camera", text, false);
      },
      [](const C& c) { return format_list(c.colour.camera_px); }));
  rows.push_back(custom_row(
      "colour_extrinsic", s,
      "depth camera pose in the colour camera's frame: tx,ty,tz (m),rx,ry,rz (rotation vector, "
      "rad); all 0 = registered images (TUM, ICL-NUIM)",
      [](C& c, const std::string& text) {
        c.colour.extrinsic = parse_floats<6>("colour_extrinsic", text, false);
      },
      [](const C& c) { return format_list(c.colour.extrinsic); }));
  return section;
}

}  // namespace kfx::settings
