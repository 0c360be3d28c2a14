#pragma once
/// The per-pipeline state that kernels read and write: the pose, the reference (raycast) view
/// and the decisions of the current frame. It lives in device memory on the GPU, so the host
/// never has to read it inside a frame; later kernels read its flags and early-out.

#include "core/math.hpp"

namespace kfx {

/// Layout of the packed ICP accumulator (docs/algorithm.md §2.2: Σe², Σe·J, JᵀJ upper triangle,
/// counts).
enum AccumulatorIndex : int {
  kAccErrorSq = 0,     ///< Σ e²
  kAccJtE = 1,         ///< Σ e·J, 6 values
  kAccJtJ = 7,         ///< upper triangle of JᵀJ, row-major, 21 values
  kAccInliers = 28,    ///< inlier count
  kAccTooFar = 29,     ///< outcome −4 count
  kAccBadNormal = 30,  ///< outcome −5 count
  kAccOtherFail = 31,  ///< outcomes −1, −2, −3 count
  kAccumulatorSize = 32,
};

/// Pose and per-frame decisions shared by all kernels of one pipeline.
struct TrackingState {
  Mat4f T_world_cam;         ///< current camera pose estimate (camera → volume frame)
  Mat4f T_world_cam_before;  ///< pose before this frame's ICP and its guess, restored on reject
  Mat4f T_world_cam_prev;    ///< T_world_cam_before of the last accepted frame (for the velocity)
  Mat4f T_cam_world;         ///< inverse of T_world_cam, set before integration
  Mat4f T_world_raycast;     ///< pose of the last raycast (the ICP reference view)
  Mat4f raycast_view;        ///< T_world_raycast · K⁻¹ at compute size (ray directions)
  Mat4f project_reference;   ///< K · T_world_raycast⁻¹ at compute size (projection into it)
  /// The photometric term's reference (kernels/photometric.hpp): world → camera of the frame
  /// whose intensity was kept last, and 1 once one was kept.
  Mat4f T_intensity_world;
  double accumulator[kAccumulatorSize];  ///< reduction of the last ICP iteration run
  double last_step_norm;                 ///< |x| of the last ICP update
  float max_depth_m;    ///< largest depth of the current frame (bounds integration)
  int converged_level;  ///< pyramid level whose ICP has converged this frame, else −1
  int tracked;          ///< outcome of this frame's accept test
  int integrate_now;    ///< 1 when this frame is integrated
  int iterations_run;   ///< ICP iterations actually run this frame (all levels)
  int frame_index;      ///< frame number f, counted on the device (−1 before frame 0)
  int accepted_run;     ///< tracked frames accepted in a row, counted up to 2 (0 after a reject)
  /// 1 from a rejected tracked frame until the next accepted one: the next accept re-acquires
  /// (the bootstrap frames, which are not tracked, leave it 0).
  int rejected_since_accept;
  // The block map (volume=blocks; 0 with the dense cube):
  int map_blocks;          ///< blocks allocated after this frame
  int map_blocks_dropped;  ///< blocks this frame's band reached that the map had no room for
  /// CUDA only: this frame's band reached more new blocks than one frame may gather on the
  /// device (its allocation would not be the CPU's); the pipeline turns it into an error.
  int map_new_blocks_overflow;
  int intensity_reference;  ///< 1 once T_intensity_world and the reference intensity are set
  /// icp_robust_pin_factor (kernels/weak_direction.hpp): the previous frame's least-pinned
  /// direction in the ICP's row coordinates, and the threshold on (j·w)² above which a row pins
  /// it and keeps full weight this frame (+∞: none does).
  float weak_direction[6];
  float weak_pin_threshold;
};

}  // namespace kfx
