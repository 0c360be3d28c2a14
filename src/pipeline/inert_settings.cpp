#include "pipeline/inert_settings.hpp"

#include <algorithm>
#include <functional>

namespace kfx {
namespace {

/// A setting and when it is read: `acts` is false where the configuration leaves it unread.
struct Dependency {
  const char* key;
  const char* needs;
  const char* now;
  std::function<bool(const PipelineConfig&, const std::string& backend)> acts;
};

bool blocks(const PipelineConfig& c) { return c.volume.kind == MapKind::kBlocks; }

/// Every setting that is read only under a condition, in the settings table's order. The
/// conditions follow the code that reads each (the settings' help texts, src/pipeline/settings/,
/// say the same).
const std::vector<Dependency>& dependencies() {
  using C = PipelineConfig;
  const auto on_cuda = [](const C&, const std::string& backend) { return backend == "cuda"; };
  const auto on_blocks = [](const C& c, const std::string&) { return blocks(c); };
  // The weak-direction pins run (icp_robust_pin_factor with a robust weight).
  const auto pins_active = [](const C& c, const std::string&) {
    return c.quality.icp_robust != IcpRobust::kNone && c.quality.icp_robust_pin_factor > 0;
  };
  static const std::vector<Dependency> table = {
      {"camera_distortion", "depth_undistortion=on", "depth_undistortion=off",
       [](const C& c, const std::string&) { return c.quality.depth_undistortion; }},
      // With blocks and voxel_size_m > 0 the voxel size is voxel_size_m (Volume::grid_res()).
      {"volume_resolution", "volume=dense, or voxel_size_m=0 with volume=blocks",
       "volume=blocks with voxel_size_m > 0, which sets the voxel size",
       [](const C& c, const std::string&) { return !blocks(c) || c.volume.voxel_size_m == 0.0f; }},
      {"voxel_size_m", "volume=blocks", "volume=dense", on_blocks},
      {"map_budget_mb", "volume=blocks", "volume=dense", on_blocks},
      {"map_swap", "volume=blocks", "volume=dense", on_blocks},
      {"map_swap_distance_m", "volume=blocks with map_swap=on", "volume=dense or map_swap=off",
       [](const C& c, const std::string&) { return blocks(c) && c.volume.map_swap; }},
      {"raycast_tile_bounds", "volume=blocks", "volume=dense", on_blocks},
      {"colour_camera", "colour=on or photometric_weight > 0", "colour=off, photometric_weight=0",
       [](const C& c, const std::string&) {
         return c.colour.fuse || c.quality.photometric_weight > 0.0f;
       }},
      {"colour_extrinsic", "colour=on or photometric_weight > 0",
       "colour=off, photometric_weight=0",
       [](const C& c, const std::string&) {
         return c.colour.fuse || c.quality.photometric_weight > 0.0f;
       }},
      // Perforation only: the pattern chooses which voxels a perforated frame skips.
      {"integration_pattern", "integration_z_stride > 1", "integration_z_stride=1",
       [](const C& c, const std::string&) { return c.approx.integration_z_stride > 1; }},
      {"icp_robust_scale_m", "icp_robust=huber or tukey", "icp_robust=none",
       [](const C& c, const std::string&) { return c.quality.icp_robust != IcpRobust::kNone; }},
      {"icp_robust_scale_noise", "icp_robust=huber or tukey", "icp_robust=none",
       [](const C& c, const std::string&) { return c.quality.icp_robust != IcpRobust::kNone; }},
      {"icp_robust_pin_factor", "icp_robust=huber or tukey", "icp_robust=none",
       [](const C& c, const std::string&) { return c.quality.icp_robust != IcpRobust::kNone; }},
      {"icp_robust_pin_floor", "icp_robust_pin_factor > 0 with icp_robust",
       "icp_robust_pin_factor=0 or icp_robust=none", pins_active},
      {"icp_robust_pin_scale", "icp_robust_pin_factor > 0 with icp_robust",
       "icp_robust_pin_factor=0 or icp_robust=none", pins_active},
      {"icp_noise_floor_m", "icp_noise_weight=nguyen", "icp_noise_weight=off",
       [](const C& c, const std::string&) {
         return c.quality.icp_noise_weight == IcpNoiseWeight::kNguyen;
       }},
      {"agreement_when_reacquiring", "min_agreement_fraction > 0", "min_agreement_fraction=0",
       [](const C& c, const std::string&) { return c.quality.min_agreement_fraction > 0.0f; }},
      {"integration_weight_ref_m", "integration_weight=depth or depth_angle",
       "integration_weight=constant",
       [](const C& c, const std::string&) {
         return c.quality.integration_weight != IntegrationWeight::kConstant;
       }},
      {"photometric_max_residual", "photometric_weight > 0", "photometric_weight=0",
       [](const C& c, const std::string&) { return c.quality.photometric_weight > 0.0f; }},
      {"cuda_pdl", "the CUDA backend", "the CPU backend", on_cuda},
      {"cuda_reduce_blocks", "the CUDA backend", "the CPU backend", on_cuda},
      {"cuda_z_chunks", "the CUDA backend", "the CPU backend", on_cuda},
      {"cuda_icp_persistent", "the CUDA backend", "the CPU backend", on_cuda},
      {"cuda_fused_preprocess", "the CUDA backend", "the CPU backend", on_cuda},
  };
  return table;
}

}  // namespace

std::vector<InertSetting> inert_settings(const PipelineConfig& config,
                                         const std::vector<std::string>& user_keys,
                                         const std::string& backend) {
  std::vector<InertSetting> inert;
  for (const Dependency& d : dependencies()) {
    if (std::find(user_keys.begin(), user_keys.end(), d.key) == user_keys.end()) continue;
    if (!d.acts(config, backend)) inert.push_back(InertSetting{d.key, d.needs, d.now});
  }
  return inert;
}

std::vector<std::string> inert_setting_warnings(const PipelineConfig& config,
                                                const std::vector<std::string>& user_keys,
                                                const std::string& backend) {
  std::vector<std::string> lines;
  for (const InertSetting& s : inert_settings(config, user_keys, backend)) {
    std::string value;
    for (const ConfigField& f : config_fields()) {
      if (f.key == s.key) value = f.format(config);
    }
    lines.push_back("setting " + s.key + "=" + value + " does nothing: it needs " + s.needs +
                    " (this reconstruction has " + s.now + ")");
  }
  return lines;
}

}  // namespace kfx
