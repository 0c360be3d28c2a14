/// Settings section `approximations`: its rows and checks.

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_approximations(const PipelineConfig& config) {
  const ApproximationSettings& approx = config.approx;
  KFX_CHECK(approx.icp_stride_px >= 1 && approx.icp_stride_px <= 16,
            "icp_stride_px must be in 1..16, got " << approx.icp_stride_px);
  KFX_CHECK(approx.integration_z_stride >= 1 && approx.integration_z_stride <= 64,
            "integration_z_stride must be in 1..64, got " << approx.integration_z_stride);
  KFX_CHECK(approx.raycast_rate >= 1, "raycast_rate must be >= 1, got " << approx.raycast_rate);
  for (int b : approx.raycast_block_px) {
    KFX_CHECK(b >= 1 && b <= 16, "raycast_block_px entries must be in 1..16, got " << b);
  }
  KFX_CHECK(approx.raycast_constant_step_m >= 0, "raycast_constant_step_m must be >= 0");
  KFX_CHECK(approx.raycast_tsdf_step_factor > 0 && approx.raycast_tsdf_step_factor <= 2,
            "raycast_tsdf_step_factor must be in (0, 2], got " << approx.raycast_tsdf_step_factor);
  KFX_CHECK(approx.raycast_step == RaycastStep::kKFusion || approx.raycast_constant_step_m == 0,
            "raycast_step=tsdf takes no raycast_constant_step_m (a constant step has no band to "
            "step through), got raycast_constant_step_m="
                << approx.raycast_constant_step_m);
  if (approx.raycast_normals == RaycastNormals::kNeighbours) {
    // Copied pixels would be their own neighbours; a span sets the gradient's, which is not used.
    KFX_CHECK(approx.raycast_block_px[0] == 1 && approx.raycast_block_px[1] == 1,
              "raycast_normals=neighbours needs raycast_block_px=1,1 (copied rays have no "
              "neighbours of their own), got "
                  << format_list(approx.raycast_block_px));
    KFX_CHECK(
        config.quality.raycast_normal_span_m == 0 && config.quality.raycast_normal_span_noise == 0,
        "raycast_normals=neighbours takes no gradient span: set raycast_normal_span_m and "
        "raycast_normal_span_noise to 0");
  }
}

}  // namespace

SettingsSection approximations_section() {
  const std::string s = "approximations";
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_approximations;
  auto& rows = section.fields;
  rows.push_back(choice_row(
      "bilateral_mode", s,
      "preprocess: exact = 5x5 Gaussian with range term; spatial3x3 = 3x3 spatial weights only",
      Choices<BilateralMode>{{"exact", BilateralMode::kExact},
                             {"spatial3x3", BilateralMode::kSpatial3x3}},
      [](C& c) -> BilateralMode& { return c.approx.bilateral_mode; }));
  rows.push_back(on_off_row("zero_padded_depth", s,
                            "preprocess: bilateral reads outside the image as 0 (on|off)",
                            [](C& c) -> bool& { return c.approx.zero_padded_depth; }));
  rows.push_back(integer_row(
      "icp_stride_px", s,
      "track: one pixel per s x s block, its contribution weighted s^2 (1 = exact, 1..16)",
      [](C& c) -> int& { return c.approx.icp_stride_px; }));
  rows.push_back(integer_row(
      "integration_z_stride", s,
      "integrate: update z = f mod s, f mod s + s, ... (slices rotate per frame; frames 0-3 "
      "fill all slices; 1 = exact)",
      [](C& c) -> int& { return c.approx.integration_z_stride; }));
  rows.push_back(choice_row(
      "integration_pattern", s,
      "integrate: which voxels a perforated frame updates: slices (z = f mod s, the thesis's) "
      "| checker (x+y+z = f mod s, spread in 3-D)",
      Choices<IntegrationPattern>{{"slices", IntegrationPattern::kSlices},
                                  {"checker", IntegrationPattern::kChecker}},
      [](C& c) -> IntegrationPattern& { return c.approx.integration_pattern; }));
  rows.push_back(choice_row(
      "ray_factor", s,
      "integrate: sdf ray factor, r^2 = (x/z)^2 + (y/z)^2: exact sqrt(1 + r^2) | approx "
      "1 + r^2/2 | thesis 1 + x/z + (y/z)^2 (the seed thesis's form, x not squared) | none 1",
      Choices<RayFactor>{{"exact", RayFactor::kExact},
                         {"approx", RayFactor::kApprox},
                         {"none", RayFactor::kNone},
                         {"thesis", RayFactor::kThesis}},
      [](C& c) -> RayFactor& { return c.approx.ray_factor; }));
  rows.push_back(on_off_row("integrate_zero_depth_test", s,
                            "integrate: skip pixels without depth (on = exact)",
                            [](C& c) -> bool& { return c.approx.integrate_zero_depth_test; }));
  rows.push_back(
      integer_row("raycast_rate", s,
                  "raycast every N-th frame; ICP tracks against the last raycast (1 = exact)",
                  [](C& c) -> int& { return c.approx.raycast_rate; }));
  rows.push_back(custom_row(
      "raycast_block_px", s,
      "raycast: one ray per bx,by pixel block (width bx, height by), copied into the block "
      "(1,1 = exact; the thesis's text says 1x2 blocks, its code copies 2x2: the thesis preset "
      "uses 2,2)",
      [](C& c, const std::string& text) {
        const auto v = parse_floats<2>("raycast_block_px", text, true);
        c.approx.raycast_block_px = {parse_integer("raycast_block_px", format_number(v[0])),
                                     parse_integer("raycast_block_px", format_number(v[1]))};
      },
      [](const C& c) { return format_list(c.approx.raycast_block_px); }));
  rows.push_back(
      number_row("raycast_constant_step_m", s,
                 "raycast: march with this constant step in metres (0 = exact adaptive steps)",
                 [](C& c) -> float& { return c.approx.raycast_constant_step_m; }));
  rows.push_back(choice_row(
      "raycast_step", s,
      "raycast: the march inside the truncation band: kfusion (one voxel a sample, exact) | tsdf "
      "(max(one voxel, raycast_tsdf_step_factor x tsdf x mu), plus one sample to refine a hit "
      "bracketed wider than a voxel)",
      Choices<RaycastStep>{{"kfusion", RaycastStep::kKFusion}, {"tsdf", RaycastStep::kTsdf}},
      [](C& c) -> RaycastStep& { return c.approx.raycast_step; }));
  rows.push_back(number_row(
      "raycast_tsdf_step_factor", s,
      "raycast_step=tsdf: the band's step as a fraction of the sampled tsdf times mu (0..2; "
      "smaller is safer and slower)",
      [](C& c) -> float& { return c.approx.raycast_tsdf_step_factor; }));
  rows.push_back(
      choice_row("raycast_interp", s,
                 "raycast: trilinear (8 voxels, exact) | two_value (nearest x,y; linear in z)",
                 Choices<RaycastInterp>{{"trilinear", RaycastInterp::kTrilinear},
                                        {"two_value", RaycastInterp::kTwoValue}},
                 [](C& c) -> RaycastInterp& { return c.approx.raycast_interp; }));
  rows.push_back(choice_row(
      "raycast_normals", s,
      "raycast: the hit's normal from the tsdf's gradient (6 samples, exact) | neighbours (from "
      "the four neighbouring rays' hits, as the input's normals from its vertices; needs "
      "raycast_block_px=1,1 and no raycast_normal_span)",
      Choices<RaycastNormals>{{"gradient", RaycastNormals::kGradient},
                              {"neighbours", RaycastNormals::kNeighbours}},
      [](C& c) -> RaycastNormals& { return c.approx.raycast_normals; }));
  return section;
}

}  // namespace kfx::settings
