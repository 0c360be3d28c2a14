#pragma once
/// JPEG colour images through libjpeg (ICL-NUIM's rgb/ folders, TUM-style folders of JPEGs).

#include <string>
#include <vector>

#include "core/image.hpp"

namespace kfx::io {

/// Reads a baseline or progressive JPEG as 8-bit RGB (grayscale JPEGs are expanded). Throws
/// kfx::Error naming the file for a missing, truncated or corrupt file.
HostImage<Rgb8> read_jpeg_rgb8(const std::string& path);

/// read_jpeg_rgb8() of a JPEG held in memory (a recording's compressed image); `name` stands
/// for the file in error messages.
HostImage<Rgb8> decode_jpeg_rgb8(const std::vector<unsigned char>& bytes, const std::string& name);

/// True when `bytes` start with the JPEG signature (FF D8 FF).
bool has_jpeg_signature(const unsigned char* bytes, size_t size);

}  // namespace kfx::io
