#pragma once
/// The one configuration object of a pipeline: every setting and approximation knob, with its
/// unit in its name and its default beside it. Command-line flags, `--set key=value`, presets and
/// the dump all go through ONE table (config_fields()), so names, help and defaults cannot drift.

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

namespace kfx {

/// Least room, metres, between map_swap_distance_m and the reach of the raycast
/// (Pipeline::swap_reach_m()): the camera moves half the room between swap passes.
constexpr float kSwapMinMarginM = 0.25f;

/// All pipeline settings. Defaults are SLAMBench KFusion's (the `exact` preset).
struct PipelineConfig {
  struct Input {
    int compute_size_ratio = 2;        ///< compute size = input size / this (1, 2, 4, 8)
    std::array<float, 4> camera_px{};  ///< fx, fy, cx, cy at input size; all 0 = format default
    double depth_scale_per_m = 0.0;    ///< PNG units per metre; 0 = format default
    /// The lens's k1, k2, p1, p2, k3 (OpenCV's order); all 0 = the format's when camera_px is
    /// the format's too (TUM fr1, fr2), else none. Used only with quality.depth_undistortion.
    LensDistortion distortion;
  } input;
  struct Volume {
    int resolution_vox = 256;                                 ///< voxels per side
    float size_m = 2.0f;                                      ///< cube side, metres
    std::array<float, 3> init_pose_factor{0.5f, 0.5f, 0.0f};  ///< first camera at factor·size
    float mu_m = 0.1f;                                        ///< TSDF truncation distance
    int max_weight = 100;                                     ///< voxel weight cap
    /// The map: the dense cube above (SLAMBench's) or 8³ voxel blocks allocated where depth
    /// lands (no cube: size_m and resolution_vox then only give the voxel size and, with
    /// init_pose_factor, the first camera's position).
    MapKind kind = MapKind::kDense;
    float voxel_size_m = 0.0f;  ///< blocks: voxel side; 0 = size_m / resolution_vox
    int map_budget_mb = 2048;   ///< blocks: memory for blocks, MiB (fixes the block capacity)
    /// blocks: when the map nears its budget, move blocks far from the camera to a host store
    /// and back when the camera nears them (map/block_swap.hpp).
    bool map_swap = true;
    /// blocks: blocks whose centres lie farther than this from the camera may be swapped out;
    /// 0 = the reach of the raycast + 2 m (Pipeline::swap_distance_m()).
    float map_swap_distance_m = 0.0f;
    /// The voxel size as the maps keep it, the ratio size / res (map/block_map.hpp).
    int grid_res() const {
      return kind == MapKind::kBlocks && voxel_size_m > 0 ? 1 : resolution_vox;
    }
    float grid_size_m() const {
      return kind == MapKind::kBlocks && voxel_size_m > 0 ? voxel_size_m : size_m;
    }
  } volume;
  struct Preprocess {
    int bilateral_radius_px = 2;              ///< window (2r+1)²
    float bilateral_spatial_sigma_px = 4.0f;  ///< Gaussian σ of the spatial weight
    float bilateral_range_sigma_m = 0.1f;     ///< σ of the range weight
  } preprocess;
  struct Tracking {
    int rate = 1;                                     ///< track frames f with f % rate == 0
    std::vector<int> iterations_per_level{10, 5, 4};  ///< ICP caps, finest level first
    float icp_threshold = 1e-5f;                      ///< stop a level when |x| is below this
    float dist_threshold_m = 0.1f;                    ///< association distance gate
    float normal_threshold = 0.8f;                    ///< association normal-dot gate
    float max_rms_error_m = 0.02f;                    ///< accept test: residual RMS limit
    float min_inlier_fraction = 0.15f;                ///< accept test: inliers / pixels
    float half_sample_range_m = 0.3f;                 ///< pyramid: robust half-sample range
  } tracking;
  struct Integration {
    int rate = 2;  ///< integrate tracked frames f with f % rate == 0 (and frames 0–3)
    /// Evaluation: frames f ≥ bootstrap with f % holdout == 0 are tracked but never integrated,
    /// so the model can be compared with frames it has not seen (0 = none held out).
    int holdout = 0;
    /// Localisation only: track against a loaded map and integrate nothing (the map stays as
    /// loaded; a robot that maps once and then navigates). Needs a loaded map.
    bool localise_only = false;
  } integration;
  struct Raycast {
    float near_m = 0.4f;          ///< near plane
    float far_m = 4.0f;           ///< far plane
    float large_step_mu = 0.75f;  ///< large march step, in units of mu
    /// Blocks: march each ray only through its tile's touched depth range (speed only).
    bool tile_bounds = true;
  } raycast;
  struct Render {
    int rate = 4;  ///< render the volume every N frames when rendering is on
  } render;
  /// The seed thesis's techniques and more, each defaulting to exact (docs/algorithm.md
  /// §5). `kfx settings` lists them with their effect and range.
  struct Approximations {
    BilateralMode bilateral_mode = BilateralMode::kExact;  ///< exact (5×5 with range) | spatial3x3
    bool zero_padded_depth = false;  ///< bilateral reads outside the image as 0
    int icp_stride_px = 1;           ///< track one pixel per s × s block, weighted s²
    int integration_z_stride = 1;    ///< integrate 1 voxel in s, rotating per frame
    IntegrationPattern integration_pattern = IntegrationPattern::kSlices;  ///< slices | checker
    RayFactor ray_factor = RayFactor::kExact;   ///< exact | approx | none
    bool integrate_zero_depth_test = true;      ///< skip pixels without depth when integrating
    int raycast_rate = 1;                       ///< raycast every N-th frame (ICP reuses the last)
    std::array<int, 2> raycast_block_px{1, 1};  ///< one ray per bx × by block, copied into it
    float raycast_constant_step_m = 0.0f;       ///< > 0: constant march step (no fine steps)
    RaycastInterp raycast_interp = RaycastInterp::kTrilinear;    ///< trilinear | two_value
    RaycastNormals raycast_normals = RaycastNormals::kGradient;  ///< gradient | neighbours
  } approx;

  /// Accuracy techniques beyond KFusion's (for a `quality` preset), each defaulting to exact:
  /// the default of every one gives SLAMBench's computation bit for bit.
  struct Quality {
    float max_depth_m = 0.0f;                 ///< drop depths beyond this; 0 = keep all
    IcpRobust icp_robust = IcpRobust::kNone;  ///< none | huber | tukey
    float icp_robust_scale_m = 0.01f;         ///< robust scale c, point-to-plane metres
    IcpNoiseWeight icp_noise_weight = IcpNoiseWeight::kOff;  ///< off | nguyen (1/σ(z)²)
    float icp_noise_floor_m = 0.0f;  ///< nguyen's floor f: (f² + σ(0.4)²)/(f² + σ(z)²); 0 = none
    /// Accept test: reject a frame whose inliers' summed ICP fit weight / compute pixels is
    /// below this (kernels/frame_logic.hpp agreement_fraction); 0 = off.
    float min_agreement_fraction = 0.0f;
    /// min_agreement_fraction applies only to the first accept after a rejected frame.
    bool agreement_when_reacquiring = false;
    /// Accept test: the residual RMS over the ICP's fit weights, sqrt(Σ w·e² / Σ w), instead of
    /// KFusion's plain RMS over the inliers (kernels/frame_logic.hpp accept_or_revert).
    bool accept_rms_weighted = false;
    IntegrationWeight integration_weight = IntegrationWeight::kConstant;  ///< constant | depth |
                                                                          ///< depth_angle
    float integration_weight_ref_m = 1.0f;  ///< full weight up to this depth, (ref/d)² beyond
    IcpMotionModel icp_motion_model = IcpMotionModel::kOff;  ///< off | constant_velocity
    /// Frames 0..n−1 are integrated untracked at the first pose, the first raycast follows frame
    /// n−1 and tracking starts at frame n (KFusion: 4).
    int bootstrap_frames = 4;
    /// Undistort the depth image with input.distortion before anything else (KFusion: off,
    /// a pinhole camera); pipeline/depth_undistortion.hpp.
    bool depth_undistortion = false;
    /// λ of the photometric tracking term (kernels/photometric.hpp, docs/tracking.md): 0 =
    /// off (KFusion's, and the ICP's sums stay bit for bit); > 0 needs colour images.
    float photometric_weight = 0.0f;
    float photometric_max_residual = 0.2f;  ///< drop photometric rows beyond this residual
    /// The raycast's normals from central differences of ± this many metres (0 = one voxel,
    /// KFusion's); kernels/raycast.hpp volume_gradient_span.
    float raycast_normal_span_m = 0.0f;
    /// ... or of ± this many times the Kinect's depth noise σ(z) at the hit, where larger.
    float raycast_normal_span_noise = 0.0f;
  } quality;

  /// Colour fused beside the TSDF (docs/colour.md). Never read by tracking: the trajectory is
  /// the same with it on or off (the photometric term, quality.photometric_weight, reads the
  /// colour images and the colour camera, not the fused colour).
  struct Colour {
    /// Fuse the frames' colour images into a colour field (memory: 8 bytes per voxel). Off in
    /// the library; `kfx` turns it on whenever the input has colour unless the user sets it.
    bool fuse = false;
    std::array<float, 4> camera_px{};  ///< colour fx, fy, cx, cy at input size; 0 = depth's
    /// The depth camera's pose in the colour camera's frame, T_colour_depth, as a translation
    /// (metres) and a rotation vector (radians): tx, ty, tz, rx, ry, rz; 0 = registered.
    std::array<float, 6> extrinsic{};
  } colour;

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
