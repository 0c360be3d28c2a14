#pragma once
/// PNG files through libpng: 8/16-bit grayscale depth images in, 16-bit grayscale and RGBA8
/// images out. Writes are atomic (temporary name, then rename).

#include <cstdint>
#include <string>
#include <vector>

#include "core/image.hpp"

namespace kfx::io {

/// What a PNG's header says about its image.
struct PngHeader {
  int width_px = 0;
  int height_px = 0;
  int bit_depth = 0;  ///< bits per channel as stored: 1, 2, 4, 8 or 16
  int channels = 0;   ///< 1 gray, 2 gray+alpha, 3 RGB, 4 RGBA (palette images: 3)
};

/// Reads only the header of the PNG at `path`. Throws kfx::Error naming the file when it cannot
/// be read or is not a PNG.
PngHeader read_png_header(const std::string& path);

/// Reads a single-channel grayscale PNG. 16-bit samples are returned as stored; 8-bit (and 1, 2,
/// 4-bit) samples keep their values (0..255, not rescaled). Colour, palette and gray+alpha images
/// are refused. Throws kfx::Error naming the file for a missing, truncated or corrupt file.
/// When `bit_depth` is given it receives the bits per sample as stored (1, 2, 4, 8 or 16).
HostImage<uint16_t> read_png_gray16(const std::string& path, int* bit_depth = nullptr);

/// Reads any PNG as 8-bit RGB (gray and palette expanded, alpha dropped, 16-bit samples reduced
/// to 8). Throws kfx::Error naming the file for a missing, truncated or corrupt file.
HostImage<Rgb8> read_png_rgb8(const std::string& path);

/// read_png_gray16() and read_png_rgb8() of a PNG held in memory (a recording's compressed
/// image); `name` stands for the file in error messages.
HostImage<uint16_t> decode_png_gray16(const std::vector<unsigned char>& bytes,
                                      const std::string& name, int* bit_depth = nullptr);
HostImage<Rgb8> decode_png_rgb8(const std::vector<unsigned char>& bytes, const std::string& name);

/// Writes `image` as an 8-bit RGB PNG, atomically. Throws kfx::Error naming the file.
void write_png_rgb8(const std::string& path, const HostImage<Rgb8>& image);

/// Writes `image` as a 16-bit grayscale PNG, atomically. Throws kfx::Error naming the file.
void write_png_gray16(const std::string& path, const HostImage<uint16_t>& image);

/// Writes `image` as an 8-bit RGBA PNG, atomically. Throws kfx::Error naming the file.
void write_png_rgba8(const std::string& path, const HostImage<Rgba8>& image);

}  // namespace kfx::io
