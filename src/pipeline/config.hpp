#pragma once
/// The one configuration object of a pipeline: every setting and approximation knob, with its
/// unit in its name and its default beside it. Command-line flags, `--set key=value`, presets and
/// the dump all go through ONE table (config_fields()), so names, help and defaults cannot drift;
/// each section of it is written beside its struct (src/pipeline/settings/).

#include <array>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "backend/backend.hpp"
#include "core/camera.hpp"
#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/raycast.hpp"
#include "kernels/render.hpp"
#include "kernels/track.hpp"
#include "pipeline/settings/approximation_settings.hpp"
#include "pipeline/settings/colour_settings.hpp"
#include "pipeline/settings/input_settings.hpp"
#include "pipeline/settings/integration_settings.hpp"
#include "pipeline/settings/preprocess_settings.hpp"
#include "pipeline/settings/quality_settings.hpp"
#include "pipeline/settings/raycast_settings.hpp"
#include "pipeline/settings/render_settings.hpp"
#include "pipeline/settings/tracking_settings.hpp"
#include "pipeline/settings/volume_settings.hpp"

namespace kfx {

/// Least room, metres, between map_swap_distance_m and the reach of the raycast
/// (Pipeline::swap_reach_m()): the camera moves half the room between swap passes.
constexpr float kSwapMinMarginM = 0.25f;

/// All pipeline settings. Defaults are SLAMBench KFusion's (the `exact` preset). Each section's
/// struct, rows (help, range, parse, format) and checks live together in
/// src/pipeline/settings/NAME_settings.{hpp,cpp}.
struct PipelineConfig {
  using Input = InputSettings;
  using Volume = VolumeSettings;
  using Preprocess = PreprocessSettings;
  using Tracking = TrackingSettings;
  using Integration = IntegrationSettings;
  using Raycast = RaycastSettings;
  using Render = RenderSettings;
  using Approximations = ApproximationSettings;
  using Quality = QualitySettings;
  using Colour = ColourSettings;

  Input input;
  Volume volume;
  Preprocess preprocess;
  Tracking tracking;
  Integration integration;
  Raycast raycast;
  Render render;
  /// The seed thesis's techniques and more, each defaulting to exact (docs/algorithm.md §5).
  Approximations approx;
  /// Accuracy techniques beyond KFusion's, each defaulting to exact.
  Quality quality;
  /// Colour fused beside the TSDF; never read by tracking.
  Colour colour;

  /// CUDA launch tuning: speed only, never results (the CPU backend ignores it).
  CudaTuning cuda;

  /// Throws kfx::Error naming the setting and the allowed range on any nonsense value.
  void validate() const;
  /// `key = value` lines for every setting, grouped by section.
  std::string dump() const;
};

/// Every stage's kernel settings, derived from one validated configuration: the pipeline hands
/// them to the backend, which adds only its buffers.
struct StageParams {
  BilateralParams bilateral;
  PyramidParams pyramid;
  IcpGuessParams icp_guess;
  IcpParams icp;
  AcceptParams accept;
  IntegrateParams integrate;
  RaycastParams raycast;
  RenderParams render;  ///< the pictures of --renders (visual only)
};

/// The colour camera of `config` (colour_camera, colour_extrinsic) for a depth camera with
/// intrinsics `input_k` at input size.
ColourCamera make_colour_camera(const PipelineConfig& config, const Intrinsics& input_k);

/// The stage settings of `config` for compute-size intrinsics `compute_k` and a compute image
/// of `compute_width_px` × `compute_height_px`.
StageParams make_stage_params(const PipelineConfig& config, const Intrinsics& compute_k,
                              int compute_width_px, int compute_height_px);

/// One configurable setting.
struct ConfigField {
  std::string key;              ///< name for --set key=value and the dump
  std::string section;          ///< which sub-struct it lives in
  std::string slambench_short;  ///< SLAMBench's short option letter, or ""
  std::string slambench_long;   ///< SLAMBench's long option name, or ""
  std::string help;             ///< one line: effect, unit, range
  std::function<void(PipelineConfig&, const std::string&)> parse;  ///< throws on bad text
  std::function<std::string(const PipelineConfig&)> format;
};

/// The table of every setting.
const std::vector<ConfigField>& config_fields();

/// Sets `key` from text; throws kfx::Error on an unknown key (listing close ones) or bad value.
void set_config_value(PipelineConfig& config, const std::string& key, const std::string& value);

/// Applies "key=value"; throws when there is no '='.
void set_config_assignment(PipelineConfig& config, const std::string& assignment);

/// Names of the presets.
std::vector<std::string> preset_names();

/// A preset's configuration; throws on an unknown name.
PipelineConfig make_preset(const std::string& name);

/// What preset `name` sets, as (key, value) in table order: every setting whose value differs
/// from exact's (empty for exact). Throws kfx::Error on an unknown name.
std::vector<std::pair<std::string, std::string>> preset_values(const std::string& name);

/// preset_values() as `key=value` strings (the form of --set and of the sweep's records).
std::vector<std::string> preset_settings(const std::string& name);

}  // namespace kfx
