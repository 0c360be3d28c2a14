#pragma once
/// Colours of mesh vertices and cloud points from the colour field beside the TSDF.

#include <vector>

#include "core/mesh.hpp"
#include "output/colour_field.hpp"

namespace kfx::output {

/// Colour of a point that no fused colour reaches (mid grey).
constexpr Rgb8 kNoColour{128, 128, 128};

/// The colour field's colour at each vertex position (sample_colour: trilinear over the voxels
/// around it that hold colour, rounded to 8 bits); kNoColour where none does.
std::vector<Rgb8> vertex_colours(const MeshVertex* vertices, size_t count,
                                 const ColourField& colour);

}  // namespace kfx::output
