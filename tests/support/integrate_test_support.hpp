#pragma once
/// A small volume, the integration arguments over it, and a whole-volume integration pass,
/// shared by the kernel-level tests (test_kernels, test_knobs, test_quality_knobs,
/// test_raycast_skip).

#include <vector>

#include "core/image.hpp"
#include "kernels/frame_logic.hpp"
#include "kernels/integrate.hpp"

namespace kfx::test {

/// A 32³ volume, 3.2 m a side (10 cm voxels), every voxel empty (tsdf 1, weight 0).
struct SmallVolume {
  int res = 32;
  std::vector<Voxel> voxels = std::vector<Voxel>(32 * 32 * 32, Voxel{32766, 0});
  VolumeView view() { return VolumeView{voxels.data(), res, 3.2f}; }
};

/// Integration of `depth`, seen with `k`, into `volume` from the pose in `s` with truncation
/// `mu_m` and the frame's farthest depth `max_depth_m`, the frame prepared as the pipeline
/// prepares it.
inline IntegrateArgs frame_integrate_args(const VolumeView& volume, const HostImage<float>& depth,
                                          const Intrinsics& k, TrackingState& s, float mu_m,
                                          float max_depth_m) {
  IntegrateArgs a;
  a.volume = volume;
  a.depth_m = depth.view();
  a.k = k;
  a.state = &s;
  a.mu_m = mu_m;
  s.max_depth_m = max_depth_m;
  prepare_integration(s, true);
  return a;
}

/// Integration of `depth` (40×30, fx = fy = 40) into `vol` from the pose in `s`, mu 0.3 m.
inline IntegrateArgs integrate_args(SmallVolume& vol, const HostImage<float>& depth,
                                    TrackingState& s) {
  return frame_integrate_args(vol.view(), depth, Intrinsics{40, 40, 20, 15}, s, 0.3f, 3.0f);
}

/// Integrates every voxel column of `a.volume`, each over its bounded z-range
/// (integrate_column_bounds, as both backends do) or, with `bounded` false, over the whole
/// column.
inline void integrate_every_column(const IntegrateArgs& a, bool bounded = true) {
  const int res = a.volume.res;
  for (int y = 0; y < res; ++y) {
    for (int x = 0; x < res; ++x) {
      int z_begin = 0, z_end = res;
      if (bounded) integrate_column_bounds(x, y, a, z_begin, z_end);
      integrate_column(x, y, z_begin, z_end, a);
    }
  }
}

}  // namespace kfx::test
