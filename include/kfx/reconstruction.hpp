#pragma once
/// A KinectFusion reconstruction: settings in, frames in one at a time, the camera's pose out
/// after each; the map on demand (mesh, point cloud, renders from the current or any pose);
/// reset; the map saved and loaded. One reconstruction is used from one thread at a time;
/// several may run at once, each on its own thread (as `kfx bench --concurrent`).

#include <memory>
#include <string>
#include <vector>

#include "kfx/camera.hpp"
#include "kfx/frame.hpp"
#include "kfx/model.hpp"
#include "kfx/sequence.hpp"
#include "kfx/settings.hpp"

namespace kfx {

/// The settings and camera actually used, after the input's recommendations and defaults.
struct ResolvedSetup {
  Settings settings;        ///< preset, the input's recommended settings, then the user's
  Camera camera;            ///< intrinsics and lens used (input size)
  std::string camera_note;  ///< one line: the intrinsics used, where from and why
  /// The intrinsics mirror the dataset's world in y (SLAMBench's ICL-NUIM convention), so a
  /// ground-truth comparison must flip y.
  bool flips_y = false;
  /// Keys whose values came from the input rather than the preset or the user: the
  /// recommendations applied, `camera` when the input's intrinsics are used, `camera_distortion`
  /// when its lens is.
  std::vector<std::string> settings_from_input;
  /// What the input's format assumed for want of a name or file saying it (a TUM-style folder
  /// that names no TUM camera: generic intrinsics, TUM's depth scale), one line each. A
  /// Reconstruction made for the sequence adds them to its first frame's warnings.
  std::vector<std::string> warnings;
};

/// Resolves `settings` for `sequence` as `kfx run` does: the preset, then the sequence's
/// recommended settings unless `settings` overrides those keys (and colour=on when the sequence
/// has colour, unless `settings` sets colour), then the overrides, and the depth scale the
/// sequence is read at where the format chose it (setting depth_scale); the camera
/// from the setting `camera` when given, else the sequence's (with its lens when the camera is
/// the format's own). Throws kfx::Error when the input has no intrinsics and none are given.
ResolvedSetup resolve_setup(const Settings& settings, const Sequence& sequence);

/// What Reconstruction::load_map() found in a map file.
struct LoadedMap {
  /// The file held the camera's pose when it was saved (format version 3 and later), and the
  /// camera is there now.
  bool pose_restored = false;
  /// What the file lacks, one line naming it ("" when nothing): a file of an older format
  /// holds no camera pose, so the camera stays where it was (set_pose() places it).
  std::string note;
};

/// Where Reconstruction::localise() found one depth image in the map.
struct Located {
  bool found = false;       ///< a pose was found (false: not from this image; nothing is guessed)
  Pose T_world_cam{};       ///< camera to map frame, metres, when found
  int keyframes_tried = 0;  ///< nearest keyframes tried (setting localise_candidates)
};

/// A reconstruction over one backend, its map allocated once at construction.
class Reconstruction {
 public:
  /// Validates `settings` for `camera` and allocates the map and buffers on the backend;
  /// throws kfx::Error naming the setting, or the memory that is missing. The setting `camera`
  /// (fx,fy,cx,cy), when given, replaces the camera's intrinsics. The setting
  /// loop_closure=online is refused: a reconstruction closes no loops (online loop closure runs
  /// in `kfx run`, and `kfx optimise` closes a finished run's: docs/loop_closure.md).
  Reconstruction(const Settings& settings, const Camera& camera);
  /// For frames of `sequence`: resolve_setup(settings, sequence), then as above.
  Reconstruction(const Settings& settings, const Sequence& sequence);
  ~Reconstruction();
  Reconstruction(Reconstruction&&) noexcept;
  Reconstruction& operator=(Reconstruction&&) noexcept;

  /// Processes the next frame and returns its result. Throws kfx::Error naming the frame, and
  /// changes nothing, when the frame is not the camera's size, is not a valid depth image (NaN,
  /// negative or infinite metres, a non-positive scale), its stamp is not finite or is earlier
  /// than the previous frame's (equal stamps are allowed), when the map fuses colour (setting
  /// colour, on by default for a Sequence with colour) and it lacks a colour image of the
  /// camera's size, or when it has a colour image that nothing uses (colour=off and no
  /// photometric term).
  FrameResult process(const FrameView& frame);
  /// The same for a frame a Sequence read, except that its colour (the input's) is not used,
  /// and no error, when the reconstruction uses none.
  FrameResult process(const SequenceFrame& frame);

  /// Submits the next frame without waiting for it (on the GPU it computes while the caller
  /// prepares the next); the frame's memory is read during the call only. Checked as process().
  void submit(const FrameView& frame);
  void submit(const SequenceFrame& frame);
  /// Waits for the oldest submitted frame and returns its result; throws when none is pending.
  FrameResult collect();
  /// Integrates the next frame at a pose given by the caller (camera to map frame, metres)
  /// instead of tracking it: the map becomes the fusion of the frames at those poses (a
  /// trajectory optimised after the run, ground truth). Waits for the frames in flight first.
  /// Checked as process(), and throws kfx::Error naming the frame when the pose is not a rigid
  /// transform. The result's pose is the one given.
  FrameResult integrate_at(const FrameView& frame, const Pose& T_world_cam);
  FrameResult integrate_at(const SequenceFrame& frame, const Pose& T_world_cam);
  /// Frames submitted and not yet collected.
  int frames_in_flight() const;
  /// Where in the map is the camera that saw `frame`? Answered from this image alone, with no
  /// use of the current pose or earlier frames: its nearest keyframes (setting relocalise's
  /// keyframe database: loaded with the map, or harvested so far) are tried, each verified by
  /// tracking the image against the map raycast from it (docs/tracking.md, "Located alone").
  /// Integrates nothing, is not a frame of the trajectory, and leaves the camera where it was.
  /// Waits for the frames in flight. Throws kfx::Error with setting relocalise off, and on a bad
  /// frame as process() does.
  Located localise(const FrameView& frame);
  Located localise(const SequenceFrame& frame);

  /// Starts over: empty map, initial pose, frame 0, trajectory cleared (buffers are kept).
  void reset();

  /// The pose after the last collected frame (the initial pose before any), or the one
  /// set_pose() or load_map() put the camera at since.
  Pose pose() const;
  /// Puts the camera at `T_world_cam` (camera to map frame, metres; a rigid transform) before
  /// the next frame, keeping the map; waits for the frames in flight. Before the first frame of
  /// a map that was not loaded, it is the first pose (the map is built from there, and
  /// reset() starts there again). Otherwise the next frame raycasts the map from there, and
  /// after a load_map() nothing is integrated until a frame is tracked against the map.
  /// Throws kfx::Error when the matrix is not a rigid transform.
  void set_pose(const Pose& T_world_cam);
  /// The first camera pose (a translation into the volume, setting init_pose_factor).
  Pose initial_pose() const;
  /// Results of every collected frame since the start or the last reset, in order.
  const std::vector<FrameResult>& trajectory() const;
  /// Frames submitted since the start or the last reset.
  int frame_count() const;

  /// The map as a triangle mesh (marching cubes; waits for submitted frames).
  TriangleMesh mesh();
  /// The surface as the last raycast saw it, as points with normals.
  PointCloud point_cloud();
  /// The map shaded (SLAMBench's renderVolume) from `T_world_cam`, at compute size; either map
  /// kind (volume=dense or blocks), either backend (the same pictures: rendered on the host from
  /// a copy of the map with the backends' kernel bodies).
  RgbaImage render(const Pose& T_world_cam);
  /// The same from the current pose.
  RgbaImage render() { return render(pose()); }
  /// The depth (metres along the optical axis, 0 where nothing is seen) of the map seen from
  /// `T_world_cam`, at compute size; either map kind, either backend (as render()).
  FloatImage render_depth(const Pose& T_world_cam);

  /// Writes the trajectory in TUM format (stamp tx ty tz qx qy qz qw, the pose after each frame,
  /// camera to map frame), byte for byte as `kfx run`'s trajectory.txt; `input` names the
  /// source in its header ("": the sequence the reconstruction was made for, if any).
  void save_trajectory(const std::string& path, const std::string& input = "") const;
  /// Writes the mesh in the format `path`'s extension names: .ply (binary PLY, as `kfx run`'s
  /// mesh.ply), .obj or .glb (output/mesh_file.hpp); throws kfx::Error, before any work, on
  /// another extension. `input` as in save_trajectory().
  void save_mesh(const std::string& path, const std::string& input = "");
  /// True when the map can be saved and loaded (both kinds can: volume=dense and blocks).
  bool map_saveable() const;
  /// Writes the map (volume.kfxtsdf, or map.kfxblocks with volume=blocks; docs/outputs.md)
  /// with the camera: its current pose (pose()) and intrinsics; throws kfx::Error where the
  /// map kind cannot be saved.
  void save_map(const std::string& path);
  /// Replaces the map by one save_map() wrote (the dense volume: same resolution and size; a block
  /// map: same voxel size) and puts the camera at the pose saved with it (older files hold none:
  /// the camera stays, and the result's note says so). From then on nothing is integrated until a
  /// frame has been tracked against the loaded map (FrameResult::tracking_quality is lost until
  /// then). Waits for the frames in flight. Throws kfx::Error naming the file when it is not a map
  /// of this kind, resolution and size, or was saved with another camera (both named).
  LoadedMap load_map(const std::string& path);

  /// The settings in force (after validation), as `kfx settings` prints them.
  std::string settings_dump() const;
  /// The camera the reconstruction was made for.
  const Camera& camera() const;
  /// Compute-size image: width, height (input size / compute_size_ratio).
  int compute_width_px() const;
  int compute_height_px() const;
  /// "cpu" or "cuda", and the device (CPU model and threads, or GPU name).
  std::string backend_name() const;
  std::string device_name() const;

 private:
  friend struct ReconstructionAccess;
  struct Impl;
  explicit Reconstruction(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace kfx
