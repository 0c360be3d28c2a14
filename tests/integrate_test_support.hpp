#pragma once
/// A small volume and the integration arguments over it, shared by the kernel-level tests of
/// the integration knobs (tests/test_knobs.cpp, tests/test_quality_knobs.cpp).

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

/// Integration of `depth` (40×30, fx = fy = 40) into `vol` from the pose in `s`, mu 0.3 m, with
/// the frame prepared as the pipeline prepares it.
inline IntegrateArgs integrate_args(SmallVolume& vol, const HostImage<float>& depth,
                                    TrackingState& s) {
  IntegrateArgs a;
  a.volume = vol.view();
  a.depth_m = depth.view();
  a.k = Intrinsics{40, 40, 20, 15};
  a.state = &s;
  a.mu_m = 0.3f;
  s.max_depth_m = 3.0f;
  prepare_integration(s, true);
  return a;
}

}  // namespace kfx::test
