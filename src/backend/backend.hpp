#pragma once
/// The backend interface: one call per pipeline stage, implemented by the CPU backend (OpenMP
/// loops) and the CUDA backend (thin __global__ stubs), both over the kernel bodies in
/// src/kernels/. The pipeline (src/pipeline/) decides which stages run; decisions that depend on
/// the frame's data (converged, tracked) are flags in the backend's TrackingState, which later
/// stages read and early-out on, so the GPU never waits for the host inside a frame.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "core/math.hpp"
#include "core/mesh.hpp"
#include "core/volume.hpp"
#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"
#include "kernels/marching_cubes.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/raycast.hpp"
#include "kernels/render.hpp"
#include "kernels/track.hpp"
#include "kernels/tracking_state.hpp"
#include "map/host_block_map.hpp"
#include "map/voxel_map.hpp"

namespace kfx {

/// CUDA launch tuning: speed only, never results (settings cuda_*; the CPU backend ignores it).
/// The one place its defaults live, measured on an H200 (bench/RESULTS.md).
struct CudaTuning {
  bool pdl = true;               ///< programmatic dependent launch (on sm_90 and newer)
  int reduce_blocks = 0;         ///< cap on the ICP reduction grid; 0 = one block per SM
  int z_chunks = 0;              ///< z-ranges per integration column; 0 = 4096 / resolution
  bool icp_persistent = true;    ///< one cooperative launch per pyramid level, not per iteration
  bool fused_preprocess = true;  ///< preprocess, then the pyramid, in one launch each
};

/// Sizes fixed for a backend's lifetime; every buffer is allocated once from these.
struct BackendSetup {
  int input_width_px = 640;
  int input_height_px = 480;
  int compute_ratio = 2;  ///< compute size = input size / ratio
  int pyramid_levels = 3;
  /// The dense cube: res³ voxels over size_m. With MapKind::kBlocks no cube is allocated and
  /// the pair only gives the voxel size, size / res (map/block_map.hpp says why as a ratio).
  int volume_res_vox = 256;
  float volume_size_m = 2.0f;
  MapKind map_kind = MapKind::kDense;
  uint32_t block_capacity = 0;  ///< MapKind::kBlocks: blocks the map holds (from its budget)
  /// CUDA device to create the backend on (−1: the calling thread's current device). The CPU
  /// backend accepts only −1. Selecting a device makes it the calling thread's current one, so
  /// a pipeline is used from the thread that created it (one thread per pipeline).
  int device_index = -1;
  /// Pipelines that run at once on this backend's GPU (`--concurrent K`): the CUDA backend's
  /// persistent ICP launch then takes a share of the multiprocessors, not all of them. Speed
  /// only: the sums, and so the results, do not depend on it.
  int pipelines_on_device = 1;
  /// CUDA launch tuning (settings cuda_*; the CPU backend ignores them).
  CudaTuning cuda;
  /// Colour fusion (setting colour): a colour field beside the TSDF, a colour input image of
  /// the input size per frame (upload_colour) and a colour render.
  bool colour = false;
  /// The photometric tracking term (setting photometric_weight > 0): a colour input image per
  /// frame (upload_colour, with colour on or off), intensity pyramids of this frame and of the
  /// kept reference frame, and keep_intensity() at the end of every frame.
  bool photometric = false;
  /// The undistortion table (pipeline/depth_undistortion.hpp), compute size: the input pixel
  /// each compute pixel reads. Empty: input (x·ratio, y·ratio), as KFusion.
  HostImage<SourcePixel> depth_source_px;
  int compute_width_px() const { return input_width_px / compute_ratio; }
  int compute_height_px() const { return input_height_px / compute_ratio; }
};

/// Pipeline stages, for timing.
enum class Stage : int { kPreprocess = 0, kTrack, kIntegrate, kRaycast, kRender, kCount };

/// Stage names as reported ("preprocess", "track", ...).
const char* stage_name(Stage stage);

/// Host copies of the renders (compute size, opaque RGBA).
struct Renders {
  HostImage<Rgba8> depth;
  HostImage<Rgba8> track;
  HostImage<Rgba8> volume;
  HostImage<Rgba8> colour;  ///< the model's colour from the camera; empty without colour
};

/// Host copies of the maps a renderer or a test wants to look at.
struct DebugMaps {
  HostImage<float> depth_m;         ///< unfiltered compute-size depth
  HostImage<float> filtered_m;      ///< bilateral output (pyramid level 0)
  HostImage<Vec3f> ref_vertex;      ///< raycast vertices
  HostImage<Vec3f> ref_normal;      ///< raycast normals
  HostImage<int8_t> track_outcome;  ///< last level-0 ICP outcome per pixel
  /// The pyramid of the last tracked frame, one image per level (level 0's depth = filtered_m).
  std::vector<HostImage<float>> level_depth_m;
  std::vector<HostImage<Vec3f>> level_vertex;
  std::vector<HostImage<Vec3f>> level_normal;
};

/// One stage-per-call backend.
///
/// The rule graph replay imposes: the CUDA backend records a frame's launches once per frame
/// shape (begin_frame) and replays that recording for every later frame of the same shape,
/// arguments included. So everything a stage call passes (its *Params and `always`) may depend
/// only on the frame's shape and on the configuration, never on the frame number or on data;
/// what does depend on them (the frame index, the pose, converged, tracked) is read by the
/// kernels from the device-side TrackingState. A new shape-dependent choice needs a bit in the
/// shape (src/pipeline/pipeline.cpp).
/// The selected map (select_map) is part of what a recording captures (its memory's addresses),
/// so the CUDA backend records per shape and per map.
class Backend {
 public:
  virtual ~Backend() = default;
  /// "cpu" or "cuda".
  virtual std::string name() const = 0;
  /// Human-readable device (CPU model and threads, or GPU name).
  virtual std::string device_name() const = 0;
  /// The GPU's PCI bus id ("0000:19:00.0"), for reading its energy; "" on the CPU.
  virtual std::string device_pci_bus_id() const { return ""; }

  /// Empties the selected map (tsdf 1, weight 0; the other maps keep theirs) and sets the pose;
  /// no reference view yet.
  virtual void reset(const Mat4f& T_world_cam) = 0;

  /// Several maps in one backend (submaps, or a map rebuilt beside the one tracked against).
  /// The backend starts with one map, map 0, made from its BackendSetup; create_map() adds an
  /// empty map of the same kind and size (a block map gets BackendSetup::block_capacity blocks
  /// of its own, so each map costs what the first does) and returns its handle, 1, 2, ...
  /// without selecting it; it throws kfx::Error when the memory cannot be had. select_map()
  /// makes a map the one every later stage call acts on (allocate_blocks, integrate, raycast,
  /// render, extract_mesh, read and upload of the volume, colours or blocks) and throws
  /// kfx::Error for a handle the backend lacks. Everything else is the backend's and stays as
  /// it is across a switch: the camera pose and tracking state, the frame's images and the
  /// reference view of the last raycast (the next frame tracks against it unless a raycast of
  /// the newly selected map comes first). Call both between frames (not inside begin_frame()
  /// .. end_frame()); frames already submitted keep the map they were recorded with.
  virtual int create_map() = 0;
  virtual void select_map(int map) = 0;
  /// Maps held (at least 1) and the selected one's handle.
  virtual int map_count() const = 0;
  virtual int selected_map() const = 0;
  /// Moves the camera to `T_world_cam` between frames, keeping the map (kernels/camera_move.hpp);
  /// call with no frame in flight.
  virtual void set_pose(const Mat4f& T_world_cam) = 0;
  /// Copies the next input depth frame (input size, millimetres, rows packed: pitch == width) to
  /// the backend; the caller's memory is read during the call only.
  virtual void upload_depth(ImageView<const uint16_t> depth_mm) = 0;
  /// Copies the next frame's colour image (input size, rows packed) to the backend; with colour
  /// or the photometric term on, call it after upload_depth() for every frame. Throws
  /// kfx::Error on a wrong size or with both off.
  virtual void upload_colour(ImageView<const Rgb8> rgb) = 0;
  /// Brackets one frame's stage calls. `shape` identifies which stages the frame runs (the
  /// pipeline derives it from the frame number alone), so the GPU can record the sequence once
  /// per shape as a graph and replay it. end_frame() submits the frame; read_state() waits.
  virtual void begin_frame(int shape) = 0;
  virtual void end_frame() = 0;
  /// mm → metres at compute size (and the frame's largest depth), then the bilateral filter;
  /// with the photometric term, also this frame's intensity pyramid from its colour image.
  virtual void preprocess(const BilateralParams& params) = 0;
  /// Builds every pyramid level's depth, vertex and normal maps.
  virtual void build_pyramid(const PyramidParams& params) = 0;
  /// Marks the start of a tracked frame (pose saved for a revert) and sets the ICP's first
  /// guess (the last pose, or with a motion model its prediction).
  virtual void begin_tracking(const IcpGuessParams& params) = 0;
  /// One ICP iteration at `level`: track, reduce, solve, update; a no-op once converged.
  virtual void icp_iteration(int level, const IcpParams& params) = 0;
  /// Up to `iterations` ICP iterations at `level`: the same as that many icp_iteration() calls
  /// (which this default makes); a backend may run them in one go (CUDA: cuda_icp_persistent).
  virtual void icp_level(int level, int iterations, const IcpParams& params) {
    for (int i = 0; i < iterations; ++i) icp_iteration(level, params);
  }
  /// Accept test on the last iteration; reverts the pose on reject.
  virtual void accept_or_revert(const AcceptParams& params) = 0;
  /// Marks this frame as not tracked (tracking skipped).
  virtual void skip_tracking() = 0;
  /// Relocalisation's candidate pose, or a frame's given pose (Pipeline::submit_at_pose): hands
  /// the backend a camera pose for the next frame's adopt_staged_pose(), in stream order, so
  /// frames may be in flight and the device never waits for the host. Call between
  /// upload_depth() and begin_frame(), and only for a frame that adopts it.
  virtual void stage_pose(const Mat4f& T_world_cam) = 0;
  /// First in a frame (before preprocess()): moves the camera to the staged pose
  /// (kernels/camera_move.hpp), forgetting the motion history, as set_pose() between frames.
  virtual void adopt_staged_pose() = 0;
  /// Photometric term only (BackendSetup::photometric): after the frame's tracking, makes this
  /// frame's intensity pyramid and pose the reference of the next frame's photometric rows when
  /// `always` (a bootstrap frame) or the frame was tracked (kernels/photometric.hpp).
  virtual void keep_intensity(bool always) = 0;
  /// Block map only (MapKind::kBlocks; a no-op for the dense cube): allocates the blocks this
  /// frame's truncation band reaches when it will be integrated (`always` or tracked), and
  /// counts in the state the blocks allocated and those dropped for lack of room.
  virtual void allocate_blocks(const IntegrateParams& /*params*/, bool /*always*/) {}
  /// Integrates the unfiltered depth at the current pose when `always` or the frame tracked.
  virtual void integrate(const IntegrateParams& params, bool always) = 0;
  /// Raycasts the volume from the current pose; it becomes the ICP reference view.
  virtual void raycast(const RaycastParams& params) = 0;
  /// Renders the current frame's depth, ICP outcomes and the volume seen from the current pose
  /// into the backend's render images (visual only; timed as Stage::kRender).
  virtual void render(const RenderParams& params) = 0;
  /// Waits for the oldest submitted frame not read yet and returns its state after the frame
  /// (frame_stage_ms() then gives that frame's stage times).
  virtual TrackingState read_state() = 0;

  /// Stage timing: marks around stages; frame_stage_ms() after read_state() gives the last
  /// frame's time per stage in milliseconds (device time on the GPU).
  virtual void begin_stage(Stage stage) = 0;
  virtual void end_stage(Stage stage) = 0;
  virtual std::array<double, static_cast<int>(Stage::kCount)> frame_stage_ms() = 0;

  /// Host copies of the intermediate maps (slow; tests and renders).
  virtual DebugMaps read_maps() = 0;
  /// Host copies of the last render() (waits for it).
  virtual Renders read_renders() = 0;
  /// Host copy of the whole volume (slow; tests and mesh export).
  virtual std::vector<Voxel> read_volume() = 0;
  /// Host copy of the colour field (res³, x fastest); empty with colour off.
  virtual std::vector<ColourVoxel> read_colour_volume() = 0;

  /// Allocates what extract_mesh() needs beyond the mesh itself (mesh_scratch_bytes()), so a
  /// volume too large to mesh fails before a run rather than after it; throws kfx::Error
  /// naming the sizes. extract_mesh() calls it when needed.
  virtual void reserve_mesh_extraction() = 0;
  /// Marching cubes over the current volume (kernels/marching_cubes.hpp): the mesh on the
  /// host, in the volume frame (metres), the same bytes run to run. The arrays are the
  /// backend's own, reused by every call (pinned memory on the GPU, so the copy from the device
  /// is one direct transfer and nothing is allocated or zero-filled per call): the view stays
  /// valid until the next extract_mesh() or the backend's end; Mesh(view) keeps a copy.
  virtual MeshView extract_mesh() = 0;
  /// Replaces the volume by `voxels` (res³ of them, x fastest), e.g. a saved volume; marks
  /// every brick touched.
  virtual void upload_volume(const std::vector<Voxel>& voxels) = 0;
  /// Replaces the dense cube's colour field by `colours` (res³, as read_colour_volume gives);
  /// throws kfx::Error without colour (BackendSetup::colour) or with a block map.
  virtual void upload_colour_volume(const std::vector<ColourVoxel>& colours) = 0;
  /// Block map only (MapKind::kBlocks): a host copy of its blocks in key order, and replacing
  /// them (e.g. by a saved map). The dense cube throws kfx::Error.
  BlockMapContents read_blocks() {
    BlockMapContents contents;
    read_blocks_into(contents);
    return contents;
  }
  virtual void upload_blocks(const BlockMapContents&) {
    KFX_FAIL("upload_blocks(): this backend keeps no block map");
  }
  /// read_blocks() into `out`, reusing its arrays' memory (the swap passes read the map again
  /// and again: fresh arrays of that size cost more in page faults than the copy).
  virtual void read_blocks_into(BlockMapContents&) {
    KFX_FAIL("read_blocks(): this backend keeps no block map");
  }
};

/// Scratch bytes mesh extraction needs for a res³ volume: a byte per voxel (owned vertex
/// counts), a vertex offset per run of 8 voxels, a triangle count and offset per column segment,
/// and two flags per 8³ brick (the mesh itself comes on top).
inline size_t mesh_scratch_bytes(int res) {
  const size_t r = static_cast<size_t>(res);
  const size_t runs = static_cast<size_t>(mc_run_count(res));
  const size_t bricks = static_cast<size_t>(bricks_per_side(res));
  return (runs << kBrickShift) + sizeof(uint32_t) * (runs + 1) +
         2 * sizeof(uint32_t) * (kMcZChunks * r * r + 1) + 2 * bricks * bricks * bricks;
}

/// Backend choice on the command line.
enum class BackendKind { kCpu, kCuda, kAuto };

/// Parses "cpu", "cuda" or "auto"; throws kfx::Error otherwise.
BackendKind parse_backend_kind(const std::string& text);

/// True when this build has the CUDA backend and a CUDA device is present.
bool cuda_available(std::string* why_not = nullptr);

/// CUDA devices visible to this process (0 in a CPU-only build or without a GPU).
int cuda_device_count();

/// Lets up to 32 CUDA streams of this process run without false dependencies: CUDA feeds every
/// stream through CUDA_DEVICE_MAX_CONNECTIONS hardware queues (8 by default), so with more
/// pipelines at once (`--concurrent`) than queues, pipelines wait on each other's kernels.
/// Keeps a value the user set. Call at process start, before anything uses CUDA.
void allow_many_cuda_streams();

/// Caps the OpenMP threads of the CPU backend's loops started from the calling thread (the
/// thread-local nthreads ICV), so that K pipelines run in K threads share the cores instead of
/// each starting a team of every core. Results do not depend on the thread count (reductions
/// add per-row partials in row order). `threads` < 1 is taken as 1.
void limit_cpu_threads_of_this_thread(int threads);

/// OpenMP threads a CPU pipeline gets by default (omp_get_max_threads of the process).
int cpu_threads_available();

/// Creates a backend; `kAuto` picks CUDA when available. Asking for CUDA in a CPU-only build or
/// without a GPU throws kfx::Error saying which.
std::unique_ptr<Backend> make_backend(BackendKind kind, const BackendSetup& setup);

/// The CPU (OpenMP) backend.
std::unique_ptr<Backend> make_cpu_backend(const BackendSetup& setup);

}  // namespace kfx
