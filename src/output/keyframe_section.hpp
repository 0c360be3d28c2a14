#pragma once
/// The keyframe database saved with a map (localise/keyframe_database.hpp): the last section
/// of `.kfxtsdf` files of format version 5 and 6 and `.kfxblocks` files of version 5 and 6
/// (docs/outputs.md), after the camera section, all little-endian:
///
///   offset  size  field
///        0     8  tag "KFXKEYF2" (or "KFXKEYF\0": the first version, without images)
///        8     8  uint64 n: bytes that follow
///       16    20  int32 width W, height H (the small depth image, pixels), ferns F, tests per
///                 fern (4), keyframes K
///       36  6·4F  the fern tests, fern by fern: uint16 x, y (pixel), threshold (mm)
///          K·F    the keyframes' codes, one byte per fern, keyframe by keyframe
///          68·K   the keyframes: int32 frame number, float32[4][4] T_map_cam, row-major
///        2·W·H·K  (version 2 only) the keyframes' small depth images, keyframe by keyframe,
///                 uint16 mm row by row, 0 for none
///
/// With it a reconstruction that loads the map can find the camera anywhere the map was seen
/// from (setting relocalise); with the images, a lost view is aligned to each candidate
/// keyframe before it is tried (setting relocalise_align). A database with a keyframe that has
/// no image (one loaded from a first-version section and grown since) is written as the first
/// version.

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <istream>
#include <string>
#include <vector>

#include "core/platform.hpp"
#include "localise/keyframe_database.hpp"

namespace kfx::output {

/// Bytes of the section before the database: the tag and the length.
constexpr uint64_t kKeyframeSectionHeaderBytes = 16;

/// Writes `keyframes` to `file` as the section above.
inline void write_keyframe_section(std::FILE* file, const KeyframeDatabase& keyframes) {
  const std::vector<uint8_t> payload = keyframes.serialise();
  const char tag[8] = {'K', 'F', 'X', 'K', 'E', 'Y', 'F', keyframes.has_images() ? '2' : '\0'};
  const uint64_t n = payload.size();
  std::fwrite(tag, 1, 8, file);
  std::fwrite(&n, 8, 1, file);
  std::fwrite(payload.data(), 1, payload.size(), file);
}

/// Reads the section from `in`, which has exactly `bytes_left` bytes left in the file; throws
/// kfx::Error naming `path` when it is truncated, its tag or length is wrong, or the database
/// in it is corrupt.
inline KeyframeDatabase read_keyframe_section(std::istream& in, uint64_t bytes_left,
                                              const std::string& path) {
  KFX_CHECK(bytes_left >= kKeyframeSectionHeaderBytes,
            path << ": the keyframe section is truncated (" << bytes_left
                 << " bytes left, its header alone has " << kKeyframeSectionHeaderBytes << ")");
  unsigned char header[kKeyframeSectionHeaderBytes];
  in.read(reinterpret_cast<char*>(header), sizeof(header));
  KFX_CHECK(in, path << ": cannot read the keyframe section");
  const bool with_images = std::memcmp(header, "KFXKEYF2", 8) == 0;
  KFX_CHECK(with_images || std::memcmp(header, "KFXKEYF\0", 8) == 0,
            path << ": the keyframe section does not start with its tag (a corrupt file)");
  uint64_t n = 0;
  std::memcpy(&n, header + 8, 8);
  KFX_CHECK(n == bytes_left - kKeyframeSectionHeaderBytes,
            path << ": the keyframe section says " << n << " bytes follow, the file has "
                 << bytes_left - kKeyframeSectionHeaderBytes << " (truncated or corrupt)");
  std::vector<uint8_t> payload(static_cast<size_t>(n));
  in.read(reinterpret_cast<char*>(payload.data()), static_cast<std::streamsize>(n));
  KFX_CHECK(in, path << ": cannot read the keyframe section");
  return KeyframeDatabase::parse(payload.data(), payload.size(), path, 0, with_images);
}

}  // namespace kfx::output
