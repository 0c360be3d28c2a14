#include "output/block_map_file.hpp"

#include <cmath>
#include <cstring>
#include <fstream>

#include "core/platform.hpp"
#include "io/binary_output_file.hpp"
#include "output/keyframe_section.hpp"

namespace kfx::output {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "block map files are copied as they lie in memory (little-endian)");
static_assert(sizeof(Voxel) == 4, "a voxel is two int16");

constexpr char kMagic[8] = {'K', 'F', 'X', 'B', 'L', 'K', 'S', '\0'};
constexpr size_t kHeaderBytes = 92;
constexpr size_t kBlockBytes = 3 * sizeof(int32_t) + kBlockVoxels * sizeof(Voxel);
constexpr size_t kBlockColourBytes = kBlockVoxels * sizeof(ColourVoxel);
static_assert(sizeof(ColourVoxel) == 8, "a colour is four uint16");

}  // namespace

bool is_block_map_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return in.gcount() == 8 && std::memcmp(magic, kMagic, 8) == 0;
}

void write_block_map_file(const std::string& path, const SavedBlockMap& saved) {
  const BlockMapContents& m = saved.map;
  KFX_CHECK(m.voxels.size() == m.keys.size() * kBlockVoxels,
            path << ": " << m.keys.size() << " blocks with " << m.voxels.size() << " voxels");
  const bool colour = !m.colours.empty();
  KFX_CHECK(!colour || m.colours.size() == m.voxels.size(),
            path << ": " << m.keys.size() << " blocks with " << m.colours.size() << " colours");
  io::BinaryOutputFile file(path, "block map");
  unsigned char header[kHeaderBytes];
  KFX_CHECK(!saved.keyframes || saved.camera, path << ": keyframes without the camera");
  const uint32_t version =
      saved.keyframes
          ? (colour ? kBlockMapFileVersionColourKeyframes : kBlockMapFileVersionKeyframes)
      : saved.camera ? (colour ? kBlockMapFileVersionColourCamera : kBlockMapFileVersionCamera)
                     : (colour ? kBlockMapFileVersionColour : kBlockMapFileVersion);
  const uint32_t res = static_cast<uint32_t>(m.grid_res);
  const uint64_t count = m.keys.size();
  std::memcpy(header, kMagic, 8);
  std::memcpy(header + 8, &version, 4);
  std::memcpy(header + 12, &res, 4);
  std::memcpy(header + 16, &m.grid_size_m, 4);
  std::memcpy(header + 20, saved.T_trajectory_map.m, 64);
  std::memcpy(header + 84, &count, 8);
  std::fwrite(header, 1, sizeof(header), file.file());
  for (size_t i = 0; i < m.keys.size(); ++i) {
    const Vec3i c = unpack_block_key(m.keys[i]);
    const int32_t coords[3] = {c.x, c.y, c.z};
    std::fwrite(coords, sizeof(int32_t), 3, file.file());
    std::fwrite(&m.voxels[i * kBlockVoxels], sizeof(Voxel), kBlockVoxels, file.file());
    if (colour) {
      std::fwrite(&m.colours[i * kBlockVoxels], sizeof(ColourVoxel), kBlockVoxels, file.file());
    }
  }
  if (saved.camera) write_map_camera(file.file(), *saved.camera);
  if (saved.keyframes) write_keyframe_section(file.file(), *saved.keyframes);
  file.commit();
}

SavedBlockMap read_block_map_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  KFX_CHECK(in, "cannot open block map '" << path << "'");
  unsigned char header[kHeaderBytes];
  in.read(reinterpret_cast<char*>(header), sizeof(header));
  KFX_CHECK(in.gcount() == static_cast<std::streamsize>(sizeof(header)),
            path << ": not a kfx block map (shorter than its " << kHeaderBytes << "-byte header)");
  KFX_CHECK(std::memcmp(header, kMagic, 8) == 0, path << ": not a kfx block map (bad magic)");
  uint32_t version = 0, res = 0;
  uint64_t count = 0;
  SavedBlockMap saved;
  BlockMapContents& m = saved.map;
  std::memcpy(&version, header + 8, 4);
  std::memcpy(&res, header + 12, 4);
  std::memcpy(&m.grid_size_m, header + 16, 4);
  std::memcpy(saved.T_trajectory_map.m, header + 20, 64);
  std::memcpy(&count, header + 84, 8);
  KFX_CHECK(version >= kBlockMapFileVersion && version <= kBlockMapFileVersionColourKeyframes,
            path << ": block map format version " << version << ", this kfx reads "
                 << kBlockMapFileVersion << " to " << kBlockMapFileVersionColourKeyframes);
  const bool colour = version % 2 == 0;
  const bool keyframes = version >= kBlockMapFileVersionKeyframes;
  const uint64_t camera_bytes = version >= kBlockMapFileVersionCamera ? kMapCameraBytes : 0;
  const size_t block_bytes = kBlockBytes + (colour ? kBlockColourBytes : 0);
  KFX_CHECK(res >= 1 && res <= 1 << 20, path << ": grid_res " << res << " outside 1 to 2^20");
  KFX_CHECK(std::isfinite(m.grid_size_m) && m.grid_size_m > 0,
            path << ": grid size " << m.grid_size_m << " m is not a positive number");
  for (const auto& row : saved.T_trajectory_map.m) {
    for (float x : row) KFX_CHECK(std::isfinite(x), path << ": frame transform is not finite");
  }
  m.grid_res = static_cast<int>(res);
  in.seekg(0, std::ios::end);
  const uint64_t size = static_cast<uint64_t>(in.tellg());
  const bool fits = size >= kHeaderBytes + camera_bytes &&
                    count <= (size - kHeaderBytes - camera_bytes) / block_bytes;
  const uint64_t want = kHeaderBytes + count * block_bytes + camera_bytes;
  KFX_CHECK(fits && (keyframes ? size >= want : size == want),
            path << ": " << size << " bytes, a map of " << count << " blocks"
                 << (colour ? " with colour" : "") << (camera_bytes ? " and its camera" : "")
                 << (keyframes ? " has at least " : " has ") << want);
  in.seekg(static_cast<std::streamoff>(kHeaderBytes));
  m.keys.resize(count);
  m.voxels.resize(count * kBlockVoxels);
  if (colour) m.colours.resize(count * kBlockVoxels);
  for (uint64_t i = 0; i < count; ++i) {
    int32_t c[3];
    in.read(reinterpret_cast<char*>(c), sizeof(c));
    in.read(reinterpret_cast<char*>(&m.voxels[i * kBlockVoxels]), kBlockVoxels * sizeof(Voxel));
    if (colour) {
      in.read(reinterpret_cast<char*>(&m.colours[i * kBlockVoxels]), kBlockColourBytes);
    }
    KFX_CHECK(in, path << ": cannot read block " << i);
    KFX_CHECK(block_coords_packable(c[0], c[1], c[2]),
              path << ": block " << i << " at (" << c[0] << ", " << c[1] << ", " << c[2]
                   << ") lies outside the map's coordinate range");
    m.keys[i] = pack_block_key(c[0], c[1], c[2]);
    KFX_CHECK(i == 0 || m.keys[i - 1] < m.keys[i], path << ": block " << i << " at (" << c[0]
                                                        << ", " << c[1] << ", " << c[2]
                                                        << ") is listed twice or out of order");
  }
  if (camera_bytes > 0) {
    unsigned char bytes[kMapCameraBytes];
    in.read(reinterpret_cast<char*>(bytes), sizeof(bytes));
    KFX_CHECK(in, path << ": cannot read the camera section");
    saved.camera = parse_map_camera(bytes, path);
  }
  if (keyframes) saved.keyframes = read_keyframe_section(in, size - want, path);
  return saved;
}

}  // namespace kfx::output
