#pragma once
/// The map seen from any pose, on the host from a copy of the map (the dense cube's voxels or
/// the block map's blocks), with the kernel bodies the backends run (raycast_pixel,
/// render_volume_pixel): the same pictures on either backend and either map kind.

#include <vector>

#include "core/image.hpp"
#include "core/volume.hpp"
#include "kernels/render.hpp"
#include "map/host_block_map.hpp"

namespace kfx::api {

/// What a camera at `T_world_cam` sees of the map.
struct ViewImages {
  HostImage<Rgba8> shaded;   ///< SLAMBench's renderVolume
  HostImage<float> depth_m;  ///< along the optical axis; 0 where no surface is hit
};

/// Raycasts `voxels` (res³, x fastest, a cube of `size_m`) for a `width_px` × `height_px`
/// camera with the intrinsics and march of `params.volume_ray`.
ViewImages render_view(std::vector<Voxel>& voxels, int res, float size_m,
                       const RenderParams& params, int width_px, int height_px,
                       const Mat4f& T_world_cam, bool want_depth);

/// The same over a block map's blocks (Pipeline::read_map(), swapped-out blocks included).
ViewImages render_view(const BlockMapContents& blocks, const RenderParams& params, int width_px,
                       int height_px, const Mat4f& T_world_cam, bool want_depth);

}  // namespace kfx::api
