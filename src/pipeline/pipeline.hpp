#pragma once
/// The one frame loop (docs/algorithm.md §2–3): preprocess → track (pyramid
/// ICP) → accept/revert → integrate → raycast. Orchestration lives here once; the backend runs
/// the stages.

#include <array>
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <optional>

#include "backend/backend.hpp"
#include "core/camera.hpp"
#include "core/image.hpp"
#include "kernels/tracking_constraint.hpp"
#include "localise/input_small_depth.hpp"
#include "localise/located_pose.hpp"
#include "localise/relocaliser.hpp"
#include "localise/tracking_judge.hpp"
#include "map/block_swap.hpp"
#include "pipeline/config.hpp"

namespace kfx {

/// What happened to one frame.
struct FrameReport {
  int index = 0;              ///< frame number f, from 0
  bool tracking_ran = false;  ///< tracking was attempted (a reference view existed, on rate)
  bool tracked = false;       ///< accept test passed (tracking_ran && !tracked: tracking lost)
  bool integrated = false;    ///< depth fused into the volume
  bool raycast = false;       ///< reference view refreshed
  bool rendered = false;      ///< the three renders were made (read them before the next submit)
  Mat4f T_world_cam;          ///< pose after the frame
  std::array<double, static_cast<int>(Stage::kCount)> stage_ms{};  ///< per-stage time
  double computation_ms = 0;   ///< preprocess + track + integrate + raycast
  int icp_iterations = 0;      ///< ICP iterations run (all levels)
  double inlier_fraction = 0;  ///< inliers / compute pixels at the last iteration
  /// Pixels whose point lay farther than the ICP's distance threshold from the raycast's point
  /// it was paired with, at the last iteration, per compute pixel: the view and the map
  /// disagree there.
  double too_far_fraction = 0;
  double bad_normal_fraction = 0;  ///< paired with a disagreeing normal / compute pixels
  /// sqrt(Σe² / inliers) of the last ICP iteration, metres (the accept test's RMS; 0 when
  /// tracking did not run or had no inliers).
  double residual_rms_m = 0;
  /// How well the last ICP iteration pinned the pose (kernels/tracking_constraint.hpp): its
  /// normal matrix's eigenvalues about the camera and the weakest direction; all 0 when
  /// tracking did not run.
  TrackingConstraint constraint{};
  /// The frame's tracking state (localise/tracking_judge.hpp): good, poor (tracked, but the
  /// view lets the pose slide) or lost. It only observes: the frame's pose and integration do
  /// not depend on it.
  TrackingQuality quality = TrackingQuality::kGood;
  /// Relocalisation (setting relocalise): the frame moved the camera to a candidate pose,
  /// raycast the map from it and was tracked against that; and the frame at which a lost
  /// camera counted as found again (its verification complete).
  bool relocalisation_attempt = false;
  bool relocalised = false;
  /// The block map (volume=blocks; 0 with the dense cube): blocks allocated after the frame,
  /// and blocks its truncation band reached that did not fit the map's budget (that part of
  /// the frame's surface was not stored).
  int map_blocks = 0;
  int map_blocks_dropped = 0;
  uint64_t map_bytes = 0;  ///< bytes the allocated blocks take (block_bytes each)
  /// Blocks swapped out to host memory (setting map_swap) after the frame, and their bytes;
  /// map_blocks counts only the active map's.
  int map_blocks_swapped = 0;
  uint64_t map_swapped_bytes = 0;
  /// Swap passes run so far, and the wall time of the one run before this frame (0 if none;
  /// outside the stages and the computation time: read, sort and write back the map).
  int map_swap_passes = 0;
  double map_swap_ms = 0;
};

/// One depth image located alone in the map (Pipeline::localise).
struct Localisation {
  bool found = false;
  Mat4f T_world_cam = Mat4f::identity();  ///< the pose found (camera to volume frame)
  /// The keyframes tried, nearest first, and what each gave (localise/located_pose.hpp).
  std::vector<LocaliseAttempt> attempts;
  int chosen = -1;            ///< the attempt whose pose was taken (−1: none)
  double computation_ms = 0;  ///< the backend's time over every pass
};

/// A KinectFusion pipeline over one backend.
class Pipeline {
 public:
  /// Validates `config`, derives every stage's parameters and allocates the backend.
  /// `input_intrinsics` are at input size (before the compute-size ratio). `device_index`: the
  /// CUDA device to run on (−1: the thread's current one; BackendSetup::device_index);
  /// `pipelines_on_device`: how many pipelines run on it at once (BackendSetup, speed only).
  Pipeline(const PipelineConfig& config, const Intrinsics& input_intrinsics, int input_width_px,
           int input_height_px, BackendKind backend_kind, int device_index = -1,
           int pipelines_on_device = 1);

  /// Processes the next depth frame (input size, millimetres) and waits for its report. With
  /// config colour.fuse on, `rgb` must be the frame's colour image (input size); with it off,
  /// `rgb` is ignored.
  FrameReport process(const HostImage<uint16_t>& depth_mm, const HostImage<Rgb8>* rgb = nullptr);
  /// Starts over: empty volume, initial pose, frame 0 (buffers and recorded graphs are kept).
  void reset();
  /// Submits the next frame without waiting (the GPU computes while the host reads on).
  /// `rgb` as in process().
  void submit(const HostImage<uint16_t>& depth_mm, const HostImage<Rgb8>* rgb = nullptr) {
    submit(depth_mm.view(), rgb != nullptr ? rgb->view() : ImageView<const Rgb8>{});
  }
  /// The same from pixels someone else owns (rows packed), read during the call only; `rgb`
  /// without data when the frame has no colour image.
  void submit(ImageView<const uint16_t> depth_mm, ImageView<const Rgb8> rgb = {});
  /// Submits the next frame at a pose given by the caller (camera to volume frame): it is not
  /// tracked, and it is integrated there whatever the tracking state (a map fused at poses
  /// known from elsewhere: a finished run's optimised trajectory, ground truth). Frames may be
  /// in flight: the pose travels with the frame, in stream order (Backend::stage_pose), so the
  /// device never waits for the host between frames. `rgb` as in submit().
  /// `raycast_view`: the frame raycasts its view at the raycast rate (the reference view a
  /// tracked frame needs, the cloud); false: it raycasts nothing, and the next tracked frame
  /// starts over from a fresh raycast (as after set_pose()). Renders need no raycast.
  void submit_at_pose(const Mat4f& T_world_cam, ImageView<const uint16_t> depth_mm,
                      ImageView<const Rgb8> rgb = {}, bool raycast_view = true);
  /// Waits for the oldest submitted frame and returns its report.
  FrameReport collect();
  /// Turns the renders on or off: when on, every frame f with f % render.rate == 0 renders
  /// (Stage::kRender, outside the computation time); read them with backend().read_renders()
  /// after collecting that frame and before submitting the next.
  void set_rendering(bool on) { rendering_ = on; }
  /// True when frame f renders (rendering on and f a multiple of render.rate).
  bool renders(int frame) const { return rendering_ && frame % config_.render.rate == 0; }
  /// Frames submitted but not collected.
  int frames_in_flight() const { return static_cast<int>(in_flight_.size()); }

  /// Work in another map of the backend between frames (no frame in flight), outside the frame
  /// sequence: loop closure verifies a candidate against an older view fused into a map of its
  /// own and rebuilds the model at optimised poses beside the one tracked against
  /// (Backend::create_map). None of these counts as a frame, renders or reaches the relocaliser
  /// or the tracking judge. They use the backend's one camera and reference view, so after them
  /// the next frame needs resume_in_map(), which puts both back. The device's frame counter
  /// (the perforated integration's phase) advances by one for each side frame.
  /// Empties map `map`.
  void clear_map(int map);
  /// Integrates `depth_mm` (input size) at `T_world_cam` into map `map`, every slice, as a
  /// bootstrap frame; `rgb` is its colour image when colour fusion is on.
  void integrate_into_map(int map, const Mat4f& T_world_cam, ImageView<const uint16_t> depth_mm,
                          ImageView<const Rgb8> rgb = {});
  /// Raycasts map `map` from `T_guess` and tracks `depth_mm` against that view with the frame
  /// loop's pyramid ICP and accept test (no motion model); the report's pose and figures are
  /// the result (tracked: the accept test passed).
  FrameReport track_in_map(int map, const Mat4f& T_guess, ImageView<const uint16_t> depth_mm);
  /// Frames go on in map `map` (the one tracked against and integrated into from now) with the
  /// camera at `T_world_cam`: its view is raycast from there at once, so the next frame is
  /// tracked against it as it would have been against the last frame's raycast.
  void resume_in_map(int map, const Mat4f& T_world_cam);

  /// Moves the camera to `T_world_cam` (volume frame) before the next frame, keeping the map;
  /// no frame may be in flight. Before the first frame of a map that was not loaded it becomes
  /// the first pose (initial_pose(), used again after reset()); otherwise the next frame
  /// raycasts the map from there and is not tracked (the reference view is new).
  /// `trusted`: the caller vouches for the pose (a pose the user gives); false for the camera a
  /// map was saved with, which the relocaliser (setting relocalise) verifies before anything is
  /// integrated.
  void set_pose(const Mat4f& T_world_cam, bool trusted = true);
  /// Says that the map was replaced by a saved one (load_map(), or the dense cube uploaded):
  /// from now until reset() no frame is integrated untracked (the bootstrap frames included),
  /// the next frame raycasts the map from the current pose, and the tracking state is lost
  /// until a frame is tracked against it. No frame may be in flight. `keyframes`: the keyframe
  /// database saved with the map, if any: with setting relocalise on, the camera is then lost
  /// until the relocaliser finds it in the map (nothing is integrated before).
  void adopt_loaded_map(std::optional<KeyframeDatabase> keyframes = std::nullopt);
  /// Where in the map is the camera that saw `depth_mm` (input size, mm; `rgb` as in submit())?
  /// Answered from this image alone, with no use of the camera's current pose: each of its
  /// nearest keyframes (setting localise_candidates) is tried as relocalisation tries one
  /// (raycast the map from the keyframe's pose, track the image against it, the accept test),
  /// a pose that passes is tried again from where it ended, and localise/located_pose.hpp
  /// decides. Integrates nothing; the camera stays where it was (the next frame raycasts the
  /// map from there afresh, as after set_pose()). Needs setting relocalise and keyframes
  /// (harvested so far, or loaded with the map); no frame may be in flight.
  Localisation localise(ImageView<const uint16_t> depth_mm, ImageView<const Rgb8> rgb = {});
  /// Relocalisation (setting relocalise): its keyframes and figures; nullptr when off.
  const Relocaliser* relocaliser() const { return relocalise_ ? &relocaliser_ : nullptr; }
  /// True after adopt_loaded_map(), until reset().
  bool map_loaded() const { return map_loaded_; }

  /// The first camera pose: a translation to init_pose_factor · volume size.
  const Mat4f& initial_pose() const { return initial_pose_; }
  /// Compute-size intrinsics.
  const Intrinsics& compute_intrinsics() const { return compute_k_; }
  Backend& backend() { return *backend_; }
  const PipelineConfig& config() const { return config_; }
  /// Bytes the colour field and its buffers take on the backend (0 with colour off).
  uint64_t colour_bytes() const;
  /// Frames submitted so far.
  int frame_count() const { return frame_; }
  /// How far from the camera the raycast may read a block (and integration write one, up to
  /// the far plane's depth), metres: the far plane's corner rays' length + mu + a block's
  /// diagonal.
  float swap_reach_m() const { return swap_reach_m_; }
  /// Blocks farther than this from the camera may be swapped out, metres
  /// (map_swap_distance_m, or swap_reach_m() + 2).
  float swap_distance_m() const { return swap_distance_m_; }
  /// Every stage's kernel settings, derived once from the configuration at construction.
  const StageParams& stage_params() const { return params_; }

  /// The block map's contents: the active map's blocks with those swapped out to host memory
  /// (volume=blocks only). Waits for the frames in flight to finish on the backend.
  BlockMapContents read_map();
  /// Replaces the block map by `contents` (a saved map) and empties the swap store.
  void load_map(const BlockMapContents& contents);
  /// The model's mesh: the backend's, or with blocks swapped out, the host's marching cubes
  /// over the whole map (the same bytes as a map that never swapped). The view lives until the
  /// next call.
  MeshView extract_mesh();

 private:
  PipelineConfig config_;
  BackendSetup setup_;
  Intrinsics compute_k_;
  Mat4f initial_pose_;
  StageParams params_;  ///< every stage's kernel settings, derived once from config_
  std::unique_ptr<Backend> backend_;
  /// A submitted frame and the host-side decisions made for it.
  struct PendingFrame {
    FrameReport report;
    bool track, may_integrate, always, attempt;
    /// Located alone at submit (setting relocalise_each_frame): the report is complete and
    /// nothing of the frame is left on the backend.
    bool done = false;
  };
  std::deque<PendingFrame> in_flight_;  ///< submitted, not yet collected
  int frame_ = 0;
  bool have_reference_ = false;  ///< a raycast has run: frames can be tracked
  bool rendering_ = false;
  TrackingJudge judge_;      ///< each collected frame's tracking state
  bool relocalise_ = false;  ///< setting relocalise
  SmallDepthParams small_params_;
  Relocaliser relocaliser_;
  InputSmallDepth input_small_;  ///< relocalisation's small image of each submitted frame
  Mat4f last_pose_;          ///< the camera after the last collected frame, or as set_pose() put it
  bool map_loaded_ = false;  ///< adopt_loaded_map() was called (until reset())
  /// The camera was moved (set_pose) or the map replaced: the next frame raycasts whatever the
  /// raycast rate says, as the old reference view belongs to another pose or map.
  bool reference_stale_ = false;
  /// The frame being submitted was placed by submit_at_pose(): not tracked, always integrated.
  bool pose_given_ = false;
  Mat4f given_pose_;                ///< its pose
  bool given_raycast_view_ = true;  ///< its raycast_view

  /// The report's tracking figures (inliers, residual, constraint) from the backend's state.
  void fill_tracking_figures(FrameReport& report, const TrackingState& state) const;
  /// Frame shapes of the side work (bits above the frames' own, Pipeline::submit()).
  static constexpr int kSideIntegrateShape = 128;
  static constexpr int kSideTrackShape = 256;
  static constexpr int kResumeShape = 512;

  /// What a side frame starts from: `depth_mm` (and `rgb` where given and colour is fused or
  /// tracked with) uploaded, `T_world_cam` staged and adopted first, the depth preprocessed.
  struct SideDepth {
    ImageView<const uint16_t> depth_mm;
    ImageView<const Rgb8> rgb;
    Mat4f T_world_cam;
  };
  /// A frame outside the frame loop's own sequence (integrate, track or resume in a side map, a
  /// pass of localise()): the five stages in order, each running what is given for it and
  /// nothing where none is, so the CUDA backend records each shape as a graph of its own.
  struct SideFrame {
    SideFrame(int frame_shape, std::optional<SideDepth> from) : shape(frame_shape), depth(from) {}
    int shape;  ///< the frame's shape: a side shape above, or the frame it replays
    /// None: the frame starts at the camera's pose and preprocesses nothing.
    std::optional<SideDepth> depth;
    std::function<void()> track, integrate, raycast;  ///< each stage's work (none: nothing)
  };
  /// Runs `frame` on the selected map; returns the state it left.
  TrackingState run_side_frame(const SideFrame& frame);
  /// Runs `work` with `map` selected, then selects the map that was selected before; the
  /// reference view is then not this map's (forget_reference()).
  void in_side_map(int map, const std::function<void()>& work);
  /// The reference view belongs to another pose or map: the next frame is not tracked against
  /// it, and raycasts a fresh one whatever the raycast rate says.
  void forget_reference();
  /// Pyramid ICP of the preprocessed frame against the reference view from `guess`, coarse to
  /// fine, then the accept test (the tracking stage of every frame that tracks).
  void track_levels(const IcpGuessParams& guess);

  /// One pass of localise(): the camera moved to `T_world_cam`, the map raycast from there and
  /// the uploaded image tracked against it; returns the state after the accept test.
  TrackingState localise_pass(ImageView<const uint16_t> depth_mm, ImageView<const Rgb8> rgb,
                              const Mat4f& T_world_cam, double& computation_ms);
  /// Moves far blocks to the swap store and near ones back (map/block_swap.hpp), before the
  /// next frame; decided in collect() (swap_due_).
  void swap_pass();
  /// Frees what the passes keep for the next pass (their copies of the map), before a read of
  /// the whole map needs memory of its own: the next pass allocates afresh.
  void release_swap_working_memory();
  BlockSwapStore swap_store_;
  BlockMapContents swap_active_;  ///< a pass's copy of the active map (its memory reused)
  float swap_reach_m_ = 0.0f;
  float swap_distance_m_ = 0.0f;
  bool swap_due_ = false;
  int swap_passes_ = 0;
  int blocks_after_pass_ = 0;              ///< active blocks when the last pass ended
  Vec3f camera_m_{};                       ///< the last collected frame's camera position
  Vec3f pass_camera_m_{};                  ///< the camera position of the last pass
  std::vector<MeshVertex> mesh_vertices_;  ///< the whole map's mesh, with blocks swapped out
  std::vector<MeshTriangle> mesh_triangles_;
};

}  // namespace kfx
