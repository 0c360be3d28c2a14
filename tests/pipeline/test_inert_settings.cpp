/// Settings that do nothing where they are set (pipeline/inert_settings.hpp): each one the user
/// sets is a warning naming what it needs, with the first frame's warnings; a preset's own
/// values and the settings that act are not.

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "kfx/kfx.hpp"
#include "pipeline/inert_settings.hpp"

namespace kfx {
namespace {

std::vector<std::string> keys(const std::vector<InertSetting>& inert) {
  std::vector<std::string> out;
  for (const auto& s : inert) out.push_back(s.key);
  return out;
}

TEST(InertSettings, MapKindBackendAndOtherSettingsDecide) {
  PipelineConfig dense;  // exact: the dense cube
  const std::vector<std::string> user = {
      "voxel_size_m", "map_budget_mb", "map_swap",           "raycast_tile_bounds",   "mu_m",
      "cuda_pdl",     "cuda_z_chunks", "icp_robust_scale_m", "icp_robust_scale_noise"};
  EXPECT_EQ(keys(inert_settings(dense, user, "cpu")),
            (std::vector<std::string>{"voxel_size_m", "map_budget_mb", "map_swap",
                                      "raycast_tile_bounds", "icp_robust_scale_m",
                                      "icp_robust_scale_noise", "cuda_pdl", "cuda_z_chunks"}));
  // On the GPU the cuda_* settings act; on blocks the block settings do.
  PipelineConfig blocks = dense;
  blocks.volume.kind = MapKind::kBlocks;
  blocks.quality.icp_robust = IcpRobust::kHuber;
  EXPECT_TRUE(inert_settings(blocks, user, "cuda").empty());
  // volume_resolution: read by the dense cube, and by blocks only while voxel_size_m is 0.
  EXPECT_TRUE(inert_settings(dense, {"volume_resolution"}, "cpu").empty());
  EXPECT_TRUE(inert_settings(blocks, {"volume_resolution"}, "cpu").empty());
  blocks.volume.voxel_size_m = 0.01f;
  EXPECT_EQ(keys(inert_settings(blocks, {"volume_resolution"}, "cpu")),
            (std::vector<std::string>{"volume_resolution"}));
  // map_swap_distance_m needs the swap on too.
  blocks.volume.map_swap = false;
  EXPECT_EQ(keys(inert_settings(blocks, {"map_swap_distance_m"}, "cpu")),
            (std::vector<std::string>{"map_swap_distance_m"}));
  // Keys the user did not set are never judged.
  EXPECT_TRUE(inert_settings(dense, {}, "cpu").empty());
}

TEST(InertSettings, WarningNamesTheValueAndWhatItNeeds) {
  PipelineConfig dense;
  dense.volume.voxel_size_m = 0.01f;
  const auto lines = inert_setting_warnings(dense, {"voxel_size_m"}, "cpu");
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0],
            "setting voxel_size_m=0.01 does nothing: it needs volume=blocks (this reconstruction "
            "has volume=dense)");
}

/// The first frame's warnings of a reconstruction made with `settings` on the CPU.
std::vector<std::string> first_warnings(const Settings& settings) {
  Camera camera;
  camera.width_px = 160;
  camera.height_px = 120;
  camera.fx_px = camera.fy_px = 130.0f;
  camera.cx_px = 79.5f;
  camera.cy_px = 59.5f;
  Reconstruction r(Settings(settings).backend("cpu"), camera);
  std::vector<uint16_t> depth(160 * 120, 1500);
  FrameView frame;
  frame.depth.data = depth.data();
  frame.depth.width_px = 160;
  frame.depth.height_px = 120;
  std::vector<std::string> first = r.process(frame).warnings;
  EXPECT_TRUE(r.process(frame).warnings.empty());  // said once
  return first;
}

bool says(const std::vector<std::string>& lines, const std::string& text) {
  for (const auto& line : lines) {
    if (line.find(text) != std::string::npos) return true;
  }
  return false;
}

TEST(InertSettings, TheReconstructionSaysThemWithItsFirstFrame) {
  const auto lines = first_warnings(
      Settings().set("volume_resolution", "64").set("voxel_size_m", "0.01").set("cuda_pdl", "off"));
  EXPECT_TRUE(says(lines, "setting voxel_size_m=0.01 does nothing: it needs volume=blocks"));
  EXPECT_TRUE(says(lines, "setting cuda_pdl=off does nothing: it needs the CUDA backend"));
  EXPECT_FALSE(says(lines, "volume_resolution"));
  // `fine` sets voxel_size_m=0.005 itself: with volume=dense it does nothing, but the user did
  // not set it, so nothing is said.
  EXPECT_FALSE(says(first_warnings(Settings("fine")
                                       .set("volume", "dense")
                                       .set("volume_resolution", "64")
                                       .set("compute_size_ratio", "2")),
                    "does nothing"));
  // The settings that act: nothing.
  EXPECT_TRUE(
      first_warnings(Settings().set("volume_resolution", "64").set("mu_m", "0.05")).empty());
}

}  // namespace
}  // namespace kfx

namespace kfx {
namespace {

TEST(InertSettings, AnInputsRecommendationThatWouldDoNothingIsLeftOut) {
  Sequence house("synthetic:scene=house,frames=2,width=160,height=120");
  // The house recommends volume=blocks with 1 cm voxels; both apply by default.
  const ResolvedSetup blocks = resolve_setup(Settings().backend("cpu"), house);
  EXPECT_EQ(blocks.settings.get("voxel_size_m"), "0.01");
  // With volume=dense the recommended voxel size would do nothing: it is not applied, so
  // config.txt does not record it and nothing warns about a setting the user never set.
  const ResolvedSetup dense =
      resolve_setup(Settings().backend("cpu").set("volume", "dense"), house);
  EXPECT_EQ(dense.settings.get("voxel_size_m"), "0");
  for (const auto& key : dense.settings_from_input) EXPECT_NE(key, "voxel_size_m");
  EXPECT_NE(std::find(dense.settings_from_input.begin(), dense.settings_from_input.end(),
                      "init_pose_factor"),
            dense.settings_from_input.end());
}

}  // namespace
}  // namespace kfx
