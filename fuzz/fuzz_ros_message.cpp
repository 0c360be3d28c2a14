/// ROS messages as recordings hold them: byte 0 picks the decoder (Image, CameraInfo,
/// CompressedImage, Transform/Float32/String), byte 1 the layout (ROS 1 or CDR, as in ROS 2
/// bags, which the ROS 1 bag target does not reach); images are then converted as a reader
/// would.

#include "core/platform.hpp"
#include "io/ros_messages.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  const auto encoding = data[1] & 1 ? kfx::io::RosEncoding::kCdr : kfx::io::RosEncoding::kRos1;
  const std::vector<uint8_t> bytes(data + 2, data + size);
  const std::string what = "fuzz message";
  try {
    switch (data[0] & 3) {
      case 0:
      case 2: {
        const kfx::io::RosImage image =
            data[0] & 2 ? kfx::io::uncompress_image(
                              kfx::io::decode_compressed_image(bytes, encoding, what), what)
                        : kfx::io::decode_image(bytes, encoding, what);
        if (kfx::io::is_depth_encoding(image.encoding)) {
          kfx::io::depth_image_mm(image, 0.00025, what);
        } else {
          kfx::io::colour_image_rgb(image, 5, 3, what);
        }
        break;
      }
      case 1:
        kfx::io::decode_camera_info(bytes, encoding, what);
        break;
      default:
        kfx::io::decode_transform(bytes, encoding, what);
        kfx::io::decode_float32(bytes, encoding, what);
        kfx::io::decode_string(bytes, encoding, what);
        kfx::io::decode_stamp_s(bytes, encoding, what);
    }
  } catch (const kfx::Error&) {
  }
  return 0;
}
