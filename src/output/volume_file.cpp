#include "output/volume_file.hpp"

#include <cmath>
#include <cstring>
#include <fstream>

#include "core/platform.hpp"
#include "io/binary_output_file.hpp"
#include "output/keyframe_section.hpp"

namespace kfx::output {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "volume files are copied as they lie in memory (little-endian)");
static_assert(sizeof(Voxel) == 4, "a voxel is two int16");
static_assert(sizeof(ColourVoxel) == 8, "a colour is four uint16");

constexpr char kMagic[8] = {'K', 'F', 'X', 'T', 'S', 'D', 'F', '\0'};
/// Largest resolution accepted when reading (2048³ voxels are 32 GiB).
constexpr uint32_t kMaxResolution = 2048;

}  // namespace

void write_volume_file(const std::string& path, const SavedVolume& v) {
  const size_t count = static_cast<size_t>(v.res) * v.res * v.res;
  KFX_CHECK(v.voxels.size() == count,
            path << ": " << v.voxels.size() << " voxels for resolution " << v.res);
  const bool colour = !v.colours.empty();
  KFX_CHECK(!colour || v.colours.size() == count,
            path << ": " << v.colours.size() << " colours for resolution " << v.res);
  io::BinaryOutputFile file(path, "volume");
  unsigned char header[kVolumeHeaderBytes];
  KFX_CHECK(!v.keyframes || v.camera, path << ": keyframes without the camera");
  const uint32_t version =
      v.keyframes ? (colour ? kVolumeFileVersionColourKeyframes : kVolumeFileVersionKeyframes)
      : v.camera  ? (colour ? kVolumeFileVersionColourCamera : kVolumeFileVersionCamera)
                  : (colour ? kVolumeFileVersionColour : kVolumeFileVersion);
  const uint32_t res = static_cast<uint32_t>(v.res);
  std::memcpy(header, kMagic, 8);
  std::memcpy(header + 8, &version, 4);
  std::memcpy(header + 12, &res, 4);
  std::memcpy(header + 16, &v.size_m, 4);
  std::memcpy(header + 20, v.T_trajectory_volume.m, 64);
  std::fwrite(header, 1, sizeof(header), file.file());
  std::fwrite(v.voxels.data(), sizeof(Voxel), v.voxels.size(), file.file());
  if (colour) std::fwrite(v.colours.data(), sizeof(ColourVoxel), v.colours.size(), file.file());
  if (v.camera) write_map_camera(file.file(), *v.camera);
  if (v.keyframes) write_keyframe_section(file.file(), *v.keyframes);
  file.commit();
}

SavedVolume read_volume_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  KFX_CHECK(in, "cannot open volume '" << path << "'");
  unsigned char header[kVolumeHeaderBytes];
  in.read(reinterpret_cast<char*>(header), sizeof(header));
  KFX_CHECK(
      in.gcount() == static_cast<std::streamsize>(sizeof(header)),
      path << ": not a kfx volume (shorter than its " << kVolumeHeaderBytes << "-byte header)");
  KFX_CHECK(std::memcmp(header, kMagic, 8) == 0, path << ": not a kfx volume (bad magic)");
  uint32_t version = 0, res = 0;
  SavedVolume v;
  std::memcpy(&version, header + 8, 4);
  std::memcpy(&res, header + 12, 4);
  std::memcpy(&v.size_m, header + 16, 4);
  std::memcpy(v.T_trajectory_volume.m, header + 20, 64);
  KFX_CHECK(version >= kVolumeFileVersion && version <= kVolumeFileVersionColourKeyframes,
            path << ": volume format version " << version << ", this kfx reads "
                 << kVolumeFileVersion << " to " << kVolumeFileVersionColourKeyframes);
  const bool colour = version % 2 == 0;
  const bool camera = version >= kVolumeFileVersionCamera;
  const bool keyframes = version >= kVolumeFileVersionKeyframes;
  KFX_CHECK(res >= 2 && res <= kMaxResolution,
            path << ": resolution " << res << " outside 2 to " << kMaxResolution);
  KFX_CHECK(std::isfinite(v.size_m) && v.size_m > 0,
            path << ": volume size " << v.size_m << " m is not a positive number");
  for (const auto& row : v.T_trajectory_volume.m) {
    for (float x : row) KFX_CHECK(std::isfinite(x), path << ": frame transform is not finite");
  }
  v.res = static_cast<int>(res);
  const size_t count = static_cast<size_t>(res) * res * res;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff want = static_cast<std::streamoff>(
      kVolumeHeaderBytes + count * (sizeof(Voxel) + (colour ? sizeof(ColourVoxel) : 0)) +
      (camera ? kMapCameraBytes : 0));
  KFX_CHECK(keyframes ? size >= want : size == want,
            path << ": " << size << " bytes, a " << res << "^3 volume"
                 << (colour ? " with colour" : "") << (camera ? " and its camera" : "")
                 << (keyframes ? " has at least " : " has ") << want);
  in.seekg(static_cast<std::streamoff>(kVolumeHeaderBytes));
  v.voxels.resize(count);
  in.read(reinterpret_cast<char*>(v.voxels.data()),
          static_cast<std::streamsize>(count * sizeof(Voxel)));
  KFX_CHECK(in, path << ": cannot read the voxels");
  if (colour) {
    v.colours.resize(count);
    in.read(reinterpret_cast<char*>(v.colours.data()),
            static_cast<std::streamsize>(count * sizeof(ColourVoxel)));
    KFX_CHECK(in, path << ": cannot read the colours");
  }
  if (camera) {
    unsigned char bytes[kMapCameraBytes];
    in.read(reinterpret_cast<char*>(bytes), sizeof(bytes));
    KFX_CHECK(in, path << ": cannot read the camera section");
    v.camera = parse_map_camera(bytes, path);
  }
  if (keyframes) {
    v.keyframes = read_keyframe_section(in, static_cast<uint64_t>(size - want), path);
  }
  return v;
}

bool any_observed(const std::vector<Voxel>& voxels) {
  for (const Voxel& v : voxels) {
    if (v.weight > 0) return true;
  }
  return false;
}

}  // namespace kfx::output
