#pragma once
/// Colour images of any supported file type (PNG or JPEG, told by the file's signature).

#include <string>

#include "core/image.hpp"

namespace kfx::io {

/// Reads the PNG or JPEG at `path` as 8-bit RGB. Throws kfx::Error naming the file when it is
/// missing, of another type, truncated or corrupt.
HostImage<Rgb8> read_colour_image(const std::string& path);

}  // namespace kfx::io
