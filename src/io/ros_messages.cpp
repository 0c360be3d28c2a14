/// Decoding of the ROS messages a depth camera's recording needs, in ROS 1 and CDR layout.

#include "io/ros_messages.hpp"

#include <cmath>
#include <cstring>
#include <sstream>

#include "core/platform.hpp"
#include "io/jpeg.hpp"
#include "io/png.hpp"

namespace kfx::io {
namespace {

// Both layouts are little-endian here (CDR's big-endian form is refused up front).
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "ROS message decoding assumes LE");

/// Largest image side and array length accepted: anything larger is a corrupt message.
constexpr uint32_t kMaxSidePx = 16384;
constexpr uint32_t kMaxArrayLength = 1u << 30;

/// Reads fields in order with bounds checks; CDR aligns each primitive to its size (counted
/// from after the 4-byte encapsulation header), ROS 1 packs them.
class Cursor {
 public:
  Cursor(const std::vector<uint8_t>& bytes, RosEncoding encoding, const std::string& what)
      : bytes_(bytes), encoding_(encoding), what_(what) {
    if (encoding_ == RosEncoding::kCdr) {
      KFX_CHECK(bytes_.size() >= 4,
                what_ << ": too short for a CDR message (" << bytes_.size() << " bytes)");
      KFX_CHECK(bytes_[0] == 0 && (bytes_[1] == 1 || bytes_[1] == 0),
                what_ << ": unknown CDR encapsulation " << int(bytes_[0]) << "," << int(bytes_[1]));
      KFX_CHECK(bytes_[1] == 1, what_ << ": big-endian CDR is not supported");
      pos_ = 4;
      origin_ = 4;
    }
  }

  template <typename T>
  T read() {
    align(sizeof(T));
    need(sizeof(T));
    T value;
    std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }

  uint32_t length(const char* field, uint32_t limit = kMaxArrayLength) {
    const uint32_t n = read<uint32_t>();
    KFX_CHECK(n <= limit, what_ << ": field " << field << " claims " << n << " elements");
    return n;
  }

  std::string string(const char* field) {
    uint32_t n = length(field);
    need(n);
    std::string text(reinterpret_cast<const char*>(bytes_.data() + pos_), n);
    pos_ += n;
    // CDR strings count their terminating NUL.
    if (encoding_ == RosEncoding::kCdr && !text.empty() && text.back() == '\0') text.pop_back();
    return text;
  }

  std::vector<uint8_t> bytes(const char* field) {
    const uint32_t n = length(field);
    need(n);
    std::vector<uint8_t> out(bytes_.begin() + static_cast<std::ptrdiff_t>(pos_),
                             bytes_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
    pos_ += n;
    return out;
  }

  /// std_msgs/Header: ROS 1 has a seq and uint32 seconds; ROS 2 int32 seconds and no seq.
  void header(double* stamp_s, std::string* frame_id) {
    if (encoding_ == RosEncoding::kRos1) read<uint32_t>();
    const double sec = encoding_ == RosEncoding::kRos1 ? read<uint32_t>() : read<int32_t>();
    const uint32_t nsec = read<uint32_t>();
    *stamp_s = sec + nsec * 1e-9;
    *frame_id = string("header.frame_id");
  }

 private:
  void align(size_t size) {
    if (encoding_ != RosEncoding::kCdr) return;
    const size_t rel = pos_ - origin_;
    pos_ += (size - rel % size) % size;
  }
  void need(size_t n) {
    KFX_CHECK(pos_ <= bytes_.size() && n <= bytes_.size() - pos_,
              what_ << ": message truncated (needs " << n << " more bytes at byte " << pos_
                    << " of " << bytes_.size() << ")");
  }

  const std::vector<uint8_t>& bytes_;
  RosEncoding encoding_;
  const std::string& what_;
  size_t pos_ = 0;
  size_t origin_ = 0;
};

uint16_t to_mm(double metres) {
  if (!(metres > 0.0) || !std::isfinite(metres)) return 0;
  const double mm = std::round(metres * 1000.0);
  return mm >= 65535.0 ? 0 : static_cast<uint16_t>(mm);
}

void check_layout(const RosImage& image, size_t bytes_per_px, const std::string& what) {
  KFX_CHECK(image.width_px > 0 && image.height_px > 0 && image.width_px <= kMaxSidePx &&
                image.height_px <= kMaxSidePx,
            what << ": absurd image size " << image.width_px << "x" << image.height_px);
  KFX_CHECK(image.step_bytes >= image.width_px * bytes_per_px,
            what << ": step " << image.step_bytes << " is shorter than a row of " << image.width_px
                 << " " << image.encoding << " pixels");
  KFX_CHECK(image.data.size() >= static_cast<size_t>(image.step_bytes) * image.height_px,
            what << ": " << image.data.size() << " data bytes, " << image.width_px << "x"
                 << image.height_px << " " << image.encoding << " needs "
                 << static_cast<size_t>(image.step_bytes) * image.height_px);
}

}  // namespace

RosImage decode_image(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                      const std::string& what) {
  Cursor c(bytes, encoding, what);
  RosImage image;
  c.header(&image.stamp_s, &image.frame_id);
  image.height_px = c.read<uint32_t>();
  image.width_px = c.read<uint32_t>();
  image.encoding = c.string("encoding");
  image.big_endian = c.read<uint8_t>() != 0;
  image.step_bytes = c.read<uint32_t>();
  image.data = c.bytes("data");
  return image;
}

RosCompressedImage decode_compressed_image(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                                           const std::string& what) {
  Cursor c(bytes, encoding, what);
  RosCompressedImage image;
  c.header(&image.stamp_s, &image.frame_id);
  image.format = c.string("format");
  image.data = c.bytes("data");
  return image;
}

double decode_stamp_s(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                      const std::string& what) {
  Cursor c(bytes, encoding, what);
  RosImage header;
  c.header(&header.stamp_s, &header.frame_id);
  return header.stamp_s;
}

std::string decode_string(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                          const std::string& what) {
  Cursor c(bytes, encoding, what);
  return c.string("data");
}

RosImage uncompress_image(const RosCompressedImage& image, const std::string& what) {
  static constexpr uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  const auto is_png_at = [&](size_t at) {
    return image.data.size() >= at + 8 &&
           std::memcmp(image.data.data() + at, kPngSignature, 8) == 0;
  };
  RosImage out;
  out.stamp_s = image.stamp_s;
  out.frame_id = image.frame_id;
  const auto fill = [&](const auto& pixels, const char* encoding, size_t bytes_per_px) {
    out.width_px = static_cast<uint32_t>(pixels.width());
    out.height_px = static_cast<uint32_t>(pixels.height());
    out.encoding = encoding;
    out.step_bytes = static_cast<uint32_t>(out.width_px * bytes_per_px);
    const auto* bytes = reinterpret_cast<const uint8_t*>(pixels.data());
    out.data.assign(bytes, bytes + static_cast<size_t>(out.step_bytes) * out.height_px);
  };
  if (image.format.find("compressedDepth") != std::string::npos) {
    // image_transport's compressedDepth: a 12-byte header (int32 format, float quantisation
    // A and B) before the PNG, which older writers leave out.
    const size_t at = is_png_at(0) ? 0 : 12;
    KFX_CHECK(is_png_at(at), what << ": compressed depth in format '" << image.format
                                  << "' is not PNG (kfx reads PNG compressedDepth)");
    const std::vector<unsigned char> png(image.data.begin() + static_cast<std::ptrdiff_t>(at),
                                         image.data.end());
    const HostImage<uint16_t> raw = decode_png_gray16(png, what);
    if (image.format.rfind("32FC1", 0) != 0) {
      fill(raw, "16UC1", 2);
      return out;
    }
    // 32FC1 is stored as quantised inverse depth: depth = A / (value − B).
    KFX_CHECK(at == 12, what << ": 32FC1 compressedDepth lacks its quantisation header");
    float quant[2];
    std::memcpy(quant, image.data.data() + 4, 8);
    HostImage<float> metres(raw.width(), raw.height());
    for (size_t i = 0; i < static_cast<size_t>(raw.width()) * raw.height(); ++i) {
      const float v = raw.data()[i];
      metres.data()[i] = v == 0 ? 0.0f : quant[0] / (v - quant[1]);
    }
    fill(metres, "32FC1", 4);
    return out;
  }
  if (is_png_at(0)) {
    fill(decode_png_rgb8(std::vector<unsigned char>(image.data.begin(), image.data.end()), what),
         "rgb8", 3);
    return out;
  }
  KFX_CHECK(
      has_jpeg_signature(image.data.data(), image.data.size()),
      what << ": compressed image in format '" << image.format << "' is neither PNG nor JPEG");
  fill(decode_jpeg_rgb8(image.data, what), "rgb8", 3);
  return out;
}

RosCameraInfo decode_camera_info(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                                 const std::string& what) {
  Cursor c(bytes, encoding, what);
  RosCameraInfo info;
  c.header(&info.stamp_s, &info.frame_id);
  info.height_px = c.read<uint32_t>();
  info.width_px = c.read<uint32_t>();
  info.distortion_model = c.string("distortion_model");
  const uint32_t n = c.length("D", 64);
  for (uint32_t i = 0; i < n; ++i) info.d.push_back(c.read<double>());
  for (double& k : info.k) k = c.read<double>();
  return info;
}

RosTransform decode_transform(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                              const std::string& what) {
  Cursor c(bytes, encoding, what);
  RosTransform t;
  for (double& v : t.translation_m) v = c.read<double>();
  for (double& v : t.rotation_xyzw) v = c.read<double>();
  return t;
}

float decode_float32(const std::vector<uint8_t>& bytes, RosEncoding encoding,
                     const std::string& what) {
  Cursor c(bytes, encoding, what);
  return c.read<float>();
}

bool is_depth_encoding(const std::string& encoding) {
  return encoding == "16UC1" || encoding == "mono16" || encoding == "32FC1";
}

bool is_colour_encoding(const std::string& encoding) {
  return encoding == "rgb8" || encoding == "bgr8" || encoding == "rgba8" || encoding == "bgra8";
}

HostImage<uint16_t> depth_image_mm(const RosImage& image, double metres_per_unit,
                                   const std::string& what) {
  KFX_CHECK(is_depth_encoding(image.encoding), what << ": unknown depth encoding '"
                                                    << image.encoding
                                                    << "' (kfx reads 16UC1, mono16 and 32FC1)");
  KFX_CHECK(!image.big_endian, what << ": big-endian depth images are not supported");
  const bool is_float = image.encoding == "32FC1";
  check_layout(image, is_float ? 4 : 2, what);
  const int w = static_cast<int>(image.width_px);
  const int h = static_cast<int>(image.height_px);
  HostImage<uint16_t> depth(w, h);
  const bool millimetres = !is_float && metres_per_unit == 0.001;
  for (int y = 0; y < h; ++y) {
    const uint8_t* row = image.data.data() + static_cast<size_t>(y) * image.step_bytes;
    for (int x = 0; x < w; ++x) {
      if (is_float) {
        float metres;
        std::memcpy(&metres, row + 4 * x, 4);
        depth(x, y) = to_mm(metres);
      } else {
        uint16_t raw;
        std::memcpy(&raw, row + 2 * x, 2);
        depth(x, y) = millimetres ? raw : to_mm(raw * metres_per_unit);
      }
    }
  }
  return depth;
}

HostImage<Rgb8> colour_image_rgb(const RosImage& image, int width_px, int height_px,
                                 const std::string& what) {
  KFX_CHECK(is_colour_encoding(image.encoding),
            what << ": unknown colour encoding '" << image.encoding
                 << "' (kfx reads rgb8, bgr8, rgba8 and bgra8)");
  const size_t channels = image.encoding.size() == 5 ? 4 : 3;
  const bool bgr = image.encoding[0] == 'b';
  check_layout(image, channels, what);
  HostImage<Rgb8> rgb(width_px, height_px);
  for (int y = 0; y < height_px; ++y) {
    const size_t sy = static_cast<size_t>(y) * image.height_px / height_px;
    const uint8_t* row = image.data.data() + sy * image.step_bytes;
    for (int x = 0; x < width_px; ++x) {
      const uint8_t* p = row + channels * (static_cast<size_t>(x) * image.width_px / width_px);
      rgb(x, y) = bgr ? Rgb8{p[2], p[1], p[0]} : Rgb8{p[0], p[1], p[2]};
    }
  }
  return rgb;
}

}  // namespace kfx::io
