#pragma once
/// The few ROS message types a depth camera's recording needs (sensor_msgs/Image,
/// sensor_msgs/CameraInfo, geometry_msgs/Transform, std_msgs/Float32), decoded from ROS 1's
/// serialisation (bags v2.0, RealSense bags) or ROS 2's CDR (rosbag2), and turned into kfx's
/// depth and colour images.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/image.hpp"

namespace kfx::io {

/// How a message's bytes are laid out.
enum class RosEncoding {
  kRos1,  ///< ROS 1 serialisation: packed little-endian, uint32-prefixed strings and arrays
  kCdr,   ///< ROS 2 CDR: a 4-byte encapsulation header, then naturally aligned fields
};

/// A sensor_msgs/Image.
struct RosImage {
  double stamp_s = 0.0;  ///< header.stamp
  std::string frame_id;
  uint32_t height_px = 0, width_px = 0;
  std::string encoding;  ///< "16UC1", "mono16", "32FC1", "rgb8", "bgr8", "rgba8", "bgra8", ...
  bool big_endian = false;
  uint32_t step_bytes = 0;
  std::vector<uint8_t> data;
};

/// A sensor_msgs/CompressedImage: image_transport's "compressed" (PNG or JPEG colour) and
/// "compressedDepth" (PNG depth behind a 12-byte header) forms.
struct RosCompressedImage {
  double stamp_s = 0.0;
  std::string frame_id;
  std::string format;  ///< e.g. "rgb8; png compressed bgr8", "16UC1; compressedDepth png"
  std::vector<uint8_t> data;
};

/// A sensor_msgs/CameraInfo (only what kfx uses).
struct RosCameraInfo {
  double stamp_s = 0.0;
  std::string frame_id;
  uint32_t height_px = 0, width_px = 0;
  std::string distortion_model;
  std::vector<double> d;
  std::array<double, 9> k{};  ///< row-major 3×3: fx 0 cx / 0 fy cy / 0 0 1
};

/// A geometry_msgs/Transform: translation (m) and rotation quaternion (x, y, z, w).
struct RosTransform {
  std::array<double, 3> translation_m{};
  std::array<double, 4> rotation_xyzw{0, 0, 0, 1};
};

/// Decoders: `what` names the message (file, topic, stamp) for errors. Each throws kfx::Error
/// naming it when the bytes are too short or hold absurd sizes.
RosImage decode_image(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                      const std::string& what);
RosCompressedImage decode_compressed_image(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                                           const std::string& what);
/// The header stamp (seconds) of a message that starts with a std_msgs/Header (Image,
/// CompressedImage, CameraInfo), without decoding the rest.
double decode_stamp_s(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                      const std::string& what);
/// A std_msgs/String's text.
std::string decode_string(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                          const std::string& what);
RosCameraInfo decode_camera_info(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                                 const std::string& what);
RosTransform decode_transform(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                              const std::string& what);
float decode_float32(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                     const std::string& what);

/// The compressed image as a plain one: "compressedDepth" PNG as 16UC1 (or 32FC1 from its
/// quantised inverse depth), "compressed" PNG or JPEG colour as rgb8. Throws kfx::Error naming
/// `what` on a format kfx does not read or a corrupt image.
RosImage uncompress_image(const RosCompressedImage& image, const std::string& what);

/// True for the encodings kfx reads as depth ("16UC1", "mono16", "32FC1").
bool is_depth_encoding(const std::string& encoding);
/// True for the encodings kfx reads as colour ("rgb8", "bgr8", "rgba8", "bgra8").
bool is_colour_encoding(const std::string& encoding);

/// The depth image in millimetres: 16-bit depth is scaled by `metres_per_unit` (ROS: 0.001;
/// RealSense: its Depth Units), 32FC1 is metres. Throws kfx::Error naming `what` on an
/// unknown encoding or a step/data size that does not match the image.
HostImage<uint16_t> depth_image_mm(const RosImage& image, double metres_per_unit,
                                   const std::string& what);

/// The colour image as RGB, resampled (nearest pixel) to width_px × height_px when it differs.
/// Throws kfx::Error naming `what` on an unknown encoding or a size mismatch.
HostImage<Rgb8> colour_image_rgb(const RosImage& image, int width_px, int height_px,
                                 const std::string& what);

}  // namespace kfx::io
