#pragma once
/// The dense cube's storage (setting `volume=dense`, SLAMBench's map), written once for host
/// and device memory (`Memory`: map/map_memory.hpp): res³ voxels, x fastest, over a cube of
/// size_m, the brick and super-brick flags the raycast skips empty space with
/// (core/volume.hpp), and with colour a colour voxel beside each voxel.

#include <cstddef>
#include <cstdint>

#include "core/colour_volume.hpp"
#include "core/volume.hpp"
#include "map/map_memory.hpp"

namespace kfx {

template <class Memory>
struct DenseCubeStore {
  template <class T>
  using Buffer = typename Memory::template Buffer<T>;

  DenseCubeStore() = default;
  /// res³ voxels over a cube of `size_m` metres; with `colour` a colour field beside them. Call
  /// clear() before use.
  DenseCubeStore(int res, float size_m, bool colour)
      : voxels(cube(res)),
        brick_touched(cube(bricks_per_side(res))),
        super_brick_touched(cube(super_bricks_per_side(res))),
        colours(colour ? cube(res) : 0),
        res(res),
        size_m(size_m) {}

  /// Every voxel empty (tsdf +1, weight 0), every colour none (weight 0), no brick touched.
  void clear(const Memory& memory) const {
    memory.fill(voxels, Voxel{static_cast<int16_t>(kTsdfScale), 0});
    memory.fill_bytes(brick_touched, 0);
    memory.fill_bytes(super_brick_touched, 0);
    memory.fill_bytes(colours, 0);  // colour 0, weight 0
  }

  /// The cube and its brick flags as the kernels see them.
  VolumeView view() const {
    return VolumeView{voxels.data(), res, size_m, brick_touched.data(), super_brick_touched.data()};
  }
  /// The colour field as the kernels see it; null data without colour.
  ColourVolumeView colour_view() const {
    return ColourVolumeView{colours.size() > 0 ? colours.data() : nullptr, res, size_m};
  }

  Buffer<Voxel> voxels;                 ///< res³ voxels, x fastest
  Buffer<uint8_t> brick_touched;        ///< one flag per 8³ brick (VolumeView::brick_touched)
  Buffer<uint8_t> super_brick_touched;  ///< one per 16³ (VolumeView::super_brick_touched)
  Buffer<ColourVoxel> colours;          ///< res³ colour voxels; empty without colour
  int res = 0;
  float size_m = 0.0f;

 private:
  static size_t cube(int side) {
    const size_t s = static_cast<size_t>(side);
    return s * s * s;
  }
};

}  // namespace kfx
