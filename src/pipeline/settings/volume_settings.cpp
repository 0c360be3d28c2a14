/// Settings section `volume`: its rows and checks.

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_volume(const PipelineConfig& config) {
  const VolumeSettings& volume = config.volume;
  KFX_CHECK(volume.resolution_vox >= 8 && volume.resolution_vox <= 1024,
            "volume_resolution must be in 8..1024 voxels, got " << volume.resolution_vox);
  KFX_CHECK(volume.size_m > 0, "volume_size_m must be > 0, got " << volume.size_m);
  KFX_CHECK(
      volume.voxel_size_m == 0.0f || (volume.voxel_size_m >= 0.001f && volume.voxel_size_m <= 1.0f),
      "voxel_size_m must be 0 (volume_size_m / volume_resolution) or in 0.001..1 m, got "
          << volume.voxel_size_m);
  KFX_CHECK(volume.map_budget_mb >= 1 && volume.map_budget_mb <= (1 << 20),
            "map_budget_mb must be in 1..1048576 MiB, got " << volume.map_budget_mb);
  KFX_CHECK(
      volume.map_swap_distance_m >= 0.0f,
      "map_swap_distance_m must be >= 0 (0 = the default), got " << volume.map_swap_distance_m);
  for (float f : volume.init_pose_factor) {
    KFX_CHECK(f >= 0 && f <= 1, "init_pose_factor components must be in [0, 1], got " << f);
  }
  KFX_CHECK(volume.mu_m > 0, "mu_m must be > 0, got " << volume.mu_m);
  KFX_CHECK(volume.max_weight >= 1 && volume.max_weight <= 32767,
            "max_weight must be in 1..32767, got " << volume.max_weight);
}

/// A cube's side, given as one value or as SLAMBench's x,y,z form with three equal values.
float parse_cube_side(const std::string& key, const std::string& text) {
  const auto v = parse_floats<3>(key, text, true);
  KFX_CHECK(v[0] == v[1] && v[1] == v[2],
            "setting '" << key << "': only cubic volumes are supported, got " << text);
  return v[0];
}

}  // namespace

SettingsSection volume_section() {
  const std::string s = "volume";
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_volume;
  auto& rows = section.fields;
  rows.push_back(custom_row(
      "volume_resolution", s, "voxels per side (8..1024; SLAMBench's x,y,z form must be a cube)",
      [](C& c, const std::string& text) {
        const float side = parse_cube_side("volume_resolution", text);
        c.volume.resolution_vox = parse_integer("volume_resolution", format_number(side));
      },
      [](const C& c) { return std::to_string(c.volume.resolution_vox); },
      {"v", "volume-resolution"}));
  rows.push_back(custom_row(
      "volume_size_m", s, "volume cube side in metres (SLAMBench's x,y,z form must be a cube)",
      [](C& c, const std::string& text) {
        c.volume.size_m = parse_cube_side("volume_size_m", text);
      },
      [](const C& c) { return format_number(c.volume.size_m); }, {"s", "volume-size"}));
  rows.push_back(custom_row(
      "init_pose_factor", s, "first camera position as fractions x,y,z of the volume size",
      [](C& c, const std::string& text) {
        c.volume.init_pose_factor = parse_floats<3>("init_pose_factor", text, false);
      },
      [](const C& c) { return format_list(c.volume.init_pose_factor); }, {"p", "init-pose"}));
  rows.push_back(
      choice_row("volume", s,
                 "the map: dense (one cube of volume_resolution^3 voxels over volume_size_m, "
                 "SLAMBench's) | blocks (8^3 voxel blocks allocated where depth lands, no cube)",
                 Choices<MapKind>{{"dense", MapKind::kDense}, {"blocks", MapKind::kBlocks}},
                 [](C& c) -> MapKind& { return c.volume.kind; }));
  rows.push_back(number_row(
      "voxel_size_m", s,
      "volume=blocks: voxel side in metres (0 = volume_size_m / volume_resolution; 0.001..1)",
      [](C& c) -> float& { return c.volume.voxel_size_m; }));
  rows.push_back(integer_row(
      "map_budget_mb", s,
      "volume=blocks: memory for voxel blocks in MiB; its blocks are all the map can hold "
      "(1..1048576)",
      [](C& c) -> int& { return c.volume.map_budget_mb; }));
  rows.push_back(on_off_row(
      "map_swap", s,
      "volume=blocks: once the map fills 7/8 of map_budget_mb, move the blocks farther than "
      "map_swap_distance_m from the camera to host memory and bring them back as the camera "
      "nears them; mesh, cloud and save include them (on|off; a run that never fills 7/8 "
      "gives the same bits either way)",
      [](C& c) -> bool& { return c.volume.map_swap; }));
  rows.push_back(number_row(
      "map_swap_distance_m", s,
      "volume=blocks, map_swap=on: blocks whose centres lie farther than this from the camera "
      "may leave the active map (0 = the raycast's reach + 2, where the reach is the distance "
      "to the far plane's corners + mu_m + a block's diagonal; else at least the reach + 0.25)",
      [](C& c) -> float& { return c.volume.map_swap_distance_m; }));
  rows.push_back(number_row("mu_m", s, "TSDF truncation distance in metres",
                            [](C& c) -> float& { return c.volume.mu_m; }, {"m", "mu"}));
  rows.push_back(integer_row("max_weight", s, "voxel weight cap (1..32767)",
                             [](C& c) -> int& { return c.volume.max_weight; }));
  return section;
}

}  // namespace kfx::settings
