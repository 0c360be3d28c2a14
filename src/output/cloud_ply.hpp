#pragma once
/// The model as a point cloud PLY: the points and normals of the last raycast (the model as the
/// last camera saw it), binary little-endian `float x y z nx ny nz` (then `uchar red green
/// blue` with colour), no faces.

#include <string>

#include "core/image.hpp"
#include "core/math.hpp"
#include "output/colour_field.hpp"

namespace kfx::output {

/// Writes every pixel of the raycast maps that holds a surface point (valid normal) to `path`
/// (temporary name, renamed when complete), coloured from `colour` unless it is empty. Returns
/// the number of points written.
size_t write_cloud_ply(const std::string& path, const HostImage<Vec3f>& vertex_m,
                       const HostImage<Vec3f>& normal, const std::string& comment,
                       const ColourField& colour = {});

}  // namespace kfx::output
