/// Recordings as readers: topic choice, intrinsics, depth scale and colour pairing over any
/// BagContainer (ROS 1, RealSense and ROS 2 bags).

#include "io/bag_reader.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "core/platform.hpp"

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

constexpr const char* kImageType = "sensor_msgs/Image";
constexpr const char* kCompressedImageType = "sensor_msgs/CompressedImage";
constexpr const char* kCameraInfoType = "sensor_msgs/CameraInfo";
constexpr const char* kStringType = "std_msgs/String";
/// RealSense's recorder names its image topics <stream>/image/data (ROS 2 form: with
/// /compressed or /compressedDepth after it), keeps the stream's CameraInfo at
/// <stream>/info/camera_info (ROS 2 form: <stream>/image/camera_info) and its extrinsic at
/// <stream>/tf/0 (ROS 2 form: a string at <stream>/tf/ref_N).
constexpr const char* kRealSenseImageSuffix = "/image/data";
/// Colour further than this from a depth image in time is not its colour.
constexpr double kMaxColourGapS = 0.1;

bool ends_with(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string parent_topic(const std::string& topic) {
  const auto slash = topic.rfind('/');
  return slash == std::string::npos ? std::string() : topic.substr(0, slash);
}

/// The image topic a compressed one transports (".../image_raw/compressedDepth" →
/// ".../image_raw"); `topic` itself otherwise.
std::string base_image_topic(const std::string& topic) {
  const auto slash = topic.rfind('/');
  if (slash != std::string::npos && topic.compare(slash + 1, 10, "compressed") == 0) {
    return topic.substr(0, slash);
  }
  return topic;
}

/// RealSense's stream prefix ("/device_0/sensor_0/Depth_0") of an image topic, "" otherwise.
std::string realsense_stream(const std::string& image_topic) {
  const std::string topic = base_image_topic(image_topic);
  const std::string suffix = kRealSenseImageSuffix;
  return ends_with(topic, suffix) ? topic.substr(0, topic.size() - suffix.size()) : std::string();
}

/// The number after `key=` in RealSense's "key=value;key=value" strings; NaN when absent.
double realsense_value(const std::string& text, const std::string& key) {
  size_t at = 0;
  while ((at = text.find(key + "=", at)) != std::string::npos) {
    if (at == 0 || text[at - 1] == ';') {
      return std::strtod(text.c_str() + at + key.size() + 1, nullptr);
    }
    at += key.size();
  }
  return std::nan("");
}

/// RealSense's "key=v0,v1,...;" list; empty when absent.
std::vector<double> realsense_list(const std::string& text, const std::string& key) {
  std::vector<double> values;
  const auto at = text.find(key + "=");
  if (at == std::string::npos) return values;
  const size_t start = at + key.size() + 1;
  const size_t end = std::min(text.find(';', start), text.size());
  std::stringstream stream(text.substr(start, end - start));
  std::string item;
  while (std::getline(stream, item, ',')) values.push_back(std::strtod(item.c_str(), nullptr));
  return values;
}

std::string list_topics(const std::vector<std::string>& names) {
  if (names.empty()) return "none";
  std::string out;
  for (const auto& name : names) out += (out.empty() ? "" : ", ") + name;
  return out;
}

/// A rotation matrix's rotation vector (axis times angle, radians).
std::array<double, 3> rotation_vector(const double r[3][3]) {
  const double cos_angle = std::clamp((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0, -1.0, 1.0);
  const double angle = std::acos(cos_angle);
  const std::array<double, 3> axis_sin = {(r[2][1] - r[1][2]) / 2.0, (r[0][2] - r[2][0]) / 2.0,
                                          (r[1][0] - r[0][1]) / 2.0};
  const double s = std::sin(angle);
  if (s < 1e-9) {
    if (cos_angle > 0) return axis_sin;  // near identity: the first-order term
    // Half a turn: the axis from the matrix's diagonal.
    std::array<double, 3> axis = {std::sqrt(std::max(0.0, (r[0][0] + 1) / 2)),
                                  std::sqrt(std::max(0.0, (r[1][1] + 1) / 2)),
                                  std::sqrt(std::max(0.0, (r[2][2] + 1) / 2))};
    if (r[0][1] < 0) axis[1] = -axis[1];
    if (r[0][2] < 0) axis[2] = -axis[2];
    return {axis[0] * angle, axis[1] * angle, axis[2] * angle};
  }
  return {axis_sin[0] * angle / s, axis_sin[1] * angle / s, axis_sin[2] * angle / s};
}

void quaternion_matrix(const std::array<double, 4>& q_xyzw, double r[3][3]) {
  double x = q_xyzw[0], y = q_xyzw[1], z = q_xyzw[2], w = q_xyzw[3];
  const double n = std::sqrt(x * x + y * y + z * z + w * w);
  if (n > 0) x /= n, y /= n, z /= n, w /= n;
  r[0][0] = 1 - 2 * (y * y + z * z), r[0][1] = 2 * (x * y - z * w), r[0][2] = 2 * (x * z + y * w);
  r[1][0] = 2 * (x * y + z * w), r[1][1] = 1 - 2 * (x * x + z * z), r[1][2] = 2 * (y * z - x * w);
  r[2][0] = 2 * (x * z - y * w), r[2][1] = 2 * (y * z + x * w), r[2][2] = 1 - 2 * (x * x + y * y);
}

std::string shortest(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.9g", value);
  return buffer;
}

class BagReader : public Reader {
 public:
  BagReader(std::unique_ptr<BagContainer> bag, const BagTopics& choice,
            const ReaderOptions& options)
      : bag_(std::move(bag)) {
    kind_ = bag_->encoding() == RosEncoding::kCdr ? "ROS 2 bag" : "ROS bag";
    const std::string where = kind_ + " '" + bag_->path() + "'";
    std::vector<std::string> images, infos;
    for (const auto& topic : bag_->topics()) {
      if (topic.type == kImageType || topic.type == kCompressedImageType) {
        images.push_back(topic.name);
        types_[topic.name] = topic.type;
      }
      if (topic.type == kStringType) types_[topic.name] = topic.type;
      if (topic.type == kCameraInfoType) infos.push_back(topic.name);
    }
    // The depth topic: named, else the one image topic holding depth.
    std::vector<std::string> depth_candidates, colour_candidates;
    for (const auto& topic : images) {
      const std::string encoding = first_image(topic).encoding;
      if (is_depth_encoding(encoding)) depth_candidates.push_back(topic);
      if (is_colour_encoding(encoding)) colour_candidates.push_back(topic);
    }
    depth_topic_ = choice.depth;
    if (depth_topic_.empty()) {
      KFX_CHECK(!depth_candidates.empty(),
                where << " has no depth topic: none of its image topics (" << list_topics(images)
                      << ") holds 16UC1, mono16 or 32FC1 depth; name one as '" << bag_->path()
                      << "?depth=/topic'");
      KFX_CHECK(depth_candidates.size() == 1,
                where << " has several depth topics (" << list_topics(depth_candidates)
                      << "); name one as '" << bag_->path() << "?depth=/topic'");
      depth_topic_ = depth_candidates.front();
    }
    require_image_topic(depth_topic_, images, "depth", where);
    const RosImage first = first_image(depth_topic_);

    KFX_CHECK(is_depth_encoding(first.encoding),
              where << ", topic '" << depth_topic_ << "', first message: unknown depth encoding '"
                    << first.encoding << "' (kfx reads 16UC1, mono16 and 32FC1)");
    width_px_ = static_cast<int>(first.width_px);
    height_px_ = static_cast<int>(first.height_px);
    depth_ = bag_->messages(depth_topic_);
    realsense_ = !realsense_stream(depth_topic_).empty();
    if (realsense_) kind_ = "RealSense recording";

    // Intrinsics from the depth camera's CameraInfo.
    depth_info_topic_ =
        choice.depth_info.empty() ? info_topic_for(depth_topic_, infos) : choice.depth_info;
    KFX_CHECK(!depth_info_topic_.empty() &&
                  std::find(infos.begin(), infos.end(), depth_info_topic_) != infos.end(),
              where << ": intrinsics missing: no sensor_msgs/CameraInfo topic "
                    << (choice.depth_info.empty() ? "for depth topic '" + depth_topic_ + "'"
                                                  : "'" + choice.depth_info + "'")
                    << " (CameraInfo topics: " << list_topics(infos) << "); name one as '"
                    << bag_->path() << "?depth_info=/topic'");
    const RosCameraInfo info = first_info(depth_info_topic_);
    intrinsics_ = intrinsics_of(info, depth_info_topic_, where);
    KFX_CHECK(info.width_px == 0 || (static_cast<int>(info.width_px) == width_px_ &&
                                     static_cast<int>(info.height_px) == height_px_),
              where << ", topic '" << depth_info_topic_ << "': CameraInfo is for " << info.width_px
                    << "x" << info.height_px << " images but the depth images on '" << depth_topic_
                    << "' are " << width_px_ << "x" << height_px_);
    if ((info.distortion_model == "plumb_bob" || info.distortion_model == "Brown Conrady" ||
         info.distortion_model == "rational_polynomial") &&
        info.d.size() >= 5) {
      distortion_ = LensDistortion{static_cast<float>(info.d[0]), static_cast<float>(info.d[1]),
                                   static_cast<float>(info.d[2]), static_cast<float>(info.d[3]),
                                   static_cast<float>(info.d[4])};
    }

    // Depth units: RealSense records its Depth Units option; ROS's 16-bit depth is millimetres.
    if (first.encoding != "32FC1") {
      metres_per_unit_ = 0.001;
      if (realsense_) {
        // ROS 1 form: a Float32 at "Depth Units"; ROS 2 form: a string at "Depth_Units".
        const std::string sensor = parent_topic(realsense_stream(depth_topic_));
        for (const char* name : {"/option/Depth Units/value", "/option/Depth_Units/value"}) {
          const std::string units = sensor + name;
          const auto messages = bag_->messages(units);
          if (messages.empty()) continue;
          const std::string what = where + ", topic '" + units + "'";
          const auto bytes = bag_->read(messages.front(), units);
          metres_per_unit_ =
              types_.count(units)
                  ? std::strtod(decode_string(bytes, bag_->encoding(), what).c_str(), nullptr)
                  : decode_float32(bytes, bag_->encoding(), what);
          KFX_CHECK(metres_per_unit_ > 0 && metres_per_unit_ < 1,
                    what << ": absurd depth units " << metres_per_unit_ << " m");
        }
        // The ROS 2 form stamps images with the recording's clock; the camera's own timestamp
        // (ms) is in the per-frame metadata string.
        metadata_topic_ = realsense_stream(depth_topic_) + "/image/metadata";
        if (types_.count(metadata_topic_)) metadata_ = bag_->messages(metadata_topic_);
      }
      if (options.depth_scale_per_m > 0) metres_per_unit_ = 1.0 / options.depth_scale_per_m;
    }

    // Colour: named, else the one colour image topic.
    if (!choice.no_colour) {
      colour_topic_ = choice.colour;
      if (colour_topic_.empty()) {
        KFX_CHECK(colour_candidates.size() <= 1,
                  where << " has several colour topics (" << list_topics(colour_candidates)
                        << "); name one as '" << bag_->path()
                        << "?colour=/topic', or colour=none for depth only");
        if (!colour_candidates.empty()) colour_topic_ = colour_candidates.front();
      }
    }
    if (!colour_topic_.empty()) {
      require_image_topic(colour_topic_, images, "colour", where);
      const RosImage colour = first_image(colour_topic_);
      KFX_CHECK(is_colour_encoding(colour.encoding),
                where << ", topic '" << colour_topic_ << "', first message: unknown colour "
                      << "encoding '" << colour.encoding
                      << "' (kfx reads rgb8, bgr8, rgba8, bgra8)");
      colour_ = bag_->messages(colour_topic_);
      colour_stamps_.assign(colour_.size(), std::nan(""));
      colour_metadata_topic_ = realsense_stream(colour_topic_) + "/image/metadata";
      if (realsense_ && types_.count(colour_metadata_topic_)) {
        colour_metadata_ = bag_->messages(colour_metadata_topic_);
      }
      set_colour_camera(colour, choice, infos, where);
    }
  }

  ReadResult next(Frame& frame) override {
    if (next_index_ >= depth_.size()) return {ReadStatus::kEnd, ""};
    const size_t index = next_index_++;
    const BagMessage& message = depth_[index];
    frame.index = static_cast<int>(index);
    std::ostringstream what;
    what << kind_ << " '" << bag_->path() << "', topic '" << depth_topic_ << "', message " << index
         << " (" << message.time_ns * 1e-9 << " s)";
    frame.source = what.str();
    try {
      const RosImage depth = read_image(depth_topic_, message, what.str());
      KFX_CHECK(static_cast<int>(depth.width_px) == width_px_ &&
                    static_cast<int>(depth.height_px) == height_px_,
                what.str() << ": image is " << depth.width_px << "x" << depth.height_px
                           << ", the first was " << width_px_ << "x" << height_px_);
      frame.depth_mm = depth_image_mm(depth, metres_per_unit_, what.str());
      frame.stamp_s = depth.stamp_s > 0 ? depth.stamp_s : message.time_ns * 1e-9;
      if (!metadata_.empty()) {
        frame.stamp_s = camera_stamp_s(message, metadata_topic_, metadata_, what.str());
      }
      frame.rgb = HostImage<Rgb8>();
      if (!colour_.empty()) read_colour(frame);
    } catch (const Error& error) {
      return {ReadStatus::kBadFrame, error.what()};
    }
    return {ReadStatus::kOk, ""};
  }

  int width_px() const override { return width_px_; }
  int height_px() const override { return height_px_; }
  int frame_count() const override { return static_cast<int>(depth_.size()); }
  std::optional<Intrinsics> default_intrinsics() const override { return intrinsics_; }
  std::string intrinsics_source() const override {
    return "CameraInfo on topic '" + depth_info_topic_ + "' of '" + bag_->path() + "'";
  }
  LensDistortion default_distortion() const override { return distortion_; }
  bool has_colour() const override { return !colour_.empty(); }
  std::vector<StampedPose> ground_truth() const override { return {}; }
  std::string description() const override {
    std::ostringstream out;
    out << kind_ << " '" << bag_->path() << "' (" << depth_.size() << " frames, depth '"
        << depth_topic_ << "' " << width_px_ << "x" << height_px_;
    if (!colour_.empty()) out << ", colour '" << colour_topic_ << "'";
    out << ")";
    return out.str();
  }
  std::vector<std::pair<std::string, std::string>> recommended_settings() const override {
    return colour_settings_;
  }

 private:
  RosImage first_image(const std::string& topic) {
    const auto messages = bag_->messages(topic);
    KFX_CHECK(!messages.empty(),
              kind_ << " '" << bag_->path() << "': topic '" << topic << "' holds no message");
    std::ostringstream what;
    what << kind_ << " '" << bag_->path() << "', topic '" << topic << "', first message";
    return read_image(topic, messages.front(), what.str());
  }

  /// An Image, or a CompressedImage uncompressed.
  RosImage read_image(const std::string& topic, const BagMessage& message,
                      const std::string& what) {
    const auto bytes = bag_->read(message, topic);
    const auto type = types_.find(topic);
    if (type != types_.end() && type->second == kCompressedImageType) {
      return uncompress_image(decode_compressed_image(bytes, bag_->encoding(), what), what);
    }
    return decode_image(bytes, bag_->encoding(), what);
  }

  /// RealSense's (ROS 2 form) camera timestamp of the image `message`, from the metadata
  /// recorded with it (`metadata`, on `metadata_topic`).
  double camera_stamp_s(const BagMessage& message, const std::string& metadata_topic,
                        const std::vector<BagMessage>& metadata, const std::string& what) {
    const auto at = std::lower_bound(metadata.begin(), metadata.end(), message.time_ns,
                                     [](const BagMessage& m, int64_t t) { return m.time_ns < t; });
    KFX_CHECK(at != metadata.end() && at->time_ns == message.time_ns,
              what << ": no metadata on '" << metadata_topic << "' recorded with it");
    const std::string text =
        decode_string(bag_->read(*at, metadata_topic), bag_->encoding(), what + " metadata");
    const double stamp_ms = realsense_value(text, "timestamp");
    KFX_CHECK(std::isfinite(stamp_ms),
              what << ": its metadata on '" << metadata_topic << "' has no timestamp");
    return stamp_ms * 1e-3;
  }

  /// A RealSense stream's extrinsic from its reference: a Transform at <stream>/tf/0 (ROS 1
  /// form) or "rotation=9 values, column-major;translation=3 values" at <stream>/tf/ref_N.
  bool realsense_extrinsic(const std::string& stream, const std::string& where, RosTransform* out) {
    for (const auto& topic : bag_->topics()) {
      if (topic.name.rfind(stream + "/tf/", 0) != 0) continue;
      const auto messages = bag_->messages(topic.name);
      const std::string what = where + ", topic '" + topic.name + "'";
      const auto bytes = bag_->read(messages.front(), topic.name);
      if (topic.type != kStringType) {
        *out = decode_transform(bytes, bag_->encoding(), what);
        return true;
      }
      const std::string text = decode_string(bytes, bag_->encoding(), what);
      const auto r = realsense_list(text, "rotation");
      const auto t = realsense_list(text, "translation");
      KFX_CHECK(r.size() == 9 && t.size() == 3,
                what << ": cannot read the extrinsic '" << text << "'");
      // Column-major rotation, as a quaternion through its rotation vector.
      const double m[3][3] = {{r[0], r[3], r[6]}, {r[1], r[4], r[7]}, {r[2], r[5], r[8]}};
      const auto v = rotation_vector(m);
      const double angle = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      const double k = angle > 1e-12 ? std::sin(angle / 2) / angle : 0.5;
      out->rotation_xyzw = {v[0] * k, v[1] * k, v[2] * k, std::cos(angle / 2)};
      out->translation_m = {t[0], t[1], t[2]};
      return true;
    }
    return false;
  }

  RosCameraInfo first_info(const std::string& topic) {
    const auto messages = bag_->messages(topic);
    std::ostringstream what;
    what << kind_ << " '" << bag_->path() << "', topic '" << topic << "', first message";
    return decode_camera_info(bag_->read(messages.front(), topic), bag_->encoding(), what.str());
  }

  void require_image_topic(const std::string& topic, const std::vector<std::string>& images,
                           const char* role, const std::string& where) const {
    KFX_CHECK(std::find(images.begin(), images.end(), topic) != images.end(),
              where << ": the " << role << " topic '" << topic
                    << "' is not a sensor_msgs/Image topic with messages (image topics: "
                    << list_topics(images) << ")");
  }

  /// The CameraInfo topic beside an image topic: ROS's <parent>/camera_info, RealSense's
  /// <stream>/info/camera_info.
  static std::string info_topic_for(const std::string& image,
                                    const std::vector<std::string>& infos) {
    std::vector<std::string> tries = {parent_topic(base_image_topic(image)) + "/camera_info"};
    if (!realsense_stream(image).empty())
      tries.push_back(realsense_stream(image) + "/info/camera_info");
    for (const auto& t : tries) {
      if (std::find(infos.begin(), infos.end(), t) != infos.end()) return t;
    }
    return "";
  }

  static Intrinsics intrinsics_of(const RosCameraInfo& info, const std::string& topic,
                                  const std::string& where) {
    const Intrinsics k{static_cast<float>(info.k[0]), static_cast<float>(info.k[4]),
                       static_cast<float>(info.k[2]), static_cast<float>(info.k[5])};
    KFX_CHECK(std::isfinite(k.fx) && std::isfinite(k.fy) && std::isfinite(k.cx) &&
                  std::isfinite(k.cy) && k.fx != 0 && k.fy != 0,
              where << ", topic '" << topic << "': intrinsics missing: the CameraInfo's K holds fx "
                    << info.k[0] << ", fy " << info.k[4]);
    return k;
  }

  /// The colour camera's intrinsics (scaled to the depth image's size, as colour is resampled
  /// to it) and the depth camera's pose in the colour camera's frame, as settings, when they
  /// differ from registered images.
  void set_colour_camera(const RosImage& colour, const BagTopics& choice,
                         const std::vector<std::string>& infos, const std::string& where) {
    const std::string info_topic =
        choice.colour_info.empty() ? info_topic_for(colour_topic_, infos) : choice.colour_info;
    if (info_topic.empty()) return;  // no CameraInfo: taken as registered to the depth images
    KFX_CHECK(std::find(infos.begin(), infos.end(), info_topic) != infos.end(),
              where << ": colour CameraInfo topic '" << info_topic << "' has no messages");
    const Intrinsics k = intrinsics_of(first_info(info_topic), info_topic, where);
    const double sx = static_cast<double>(width_px_) / colour.width_px;
    const double sy = static_cast<double>(height_px_) / colour.height_px;
    // Pixel centres map as (x + 0.5) * s - 0.5 under nearest resampling of whole images.
    const std::array<double, 4> colour_k = {k.fx * sx, k.fy * sy, (k.cx + 0.5) * sx - 0.5,
                                            (k.cy + 0.5) * sy - 0.5};
    std::array<double, 6> extrinsic{};
    const std::string depth_stream = realsense_stream(depth_topic_);
    const std::string colour_stream = realsense_stream(colour_topic_);
    if (!depth_stream.empty() && !colour_stream.empty()) {
      // RealSense records each stream's extrinsic from its device's reference stream.
      RosTransform d, c;
      if (realsense_extrinsic(depth_stream, where, &d) &&
          realsense_extrinsic(colour_stream, where, &c)) {
        double rd[3][3], rc[3][3], r[3][3];
        quaternion_matrix(d.rotation_xyzw, rd);
        quaternion_matrix(c.rotation_xyzw, rc);
        // Each maps the reference into its stream (p_s = Rs p_ref + ts; checked against
        // recordings librealsense wrote with a known extrinsic), so
        // p_colour = Rc Rdᵀ (p_depth − td) + tc.
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) {
            r[i][j] = 0;
            for (int m = 0; m < 3; ++m) r[i][j] += rc[i][m] * rd[j][m];
          }
        }
        for (int i = 0; i < 3; ++i) {
          extrinsic[i] = c.translation_m[i];
          for (int m = 0; m < 3; ++m) extrinsic[i] -= r[i][m] * d.translation_m[m];
        }
        const auto w = rotation_vector(r);
        for (int i = 0; i < 3; ++i) extrinsic[3 + i] = w[i];
      }
    }
    const bool same_k = std::abs(colour_k[0] - intrinsics_.fx) < 1e-4 &&
                        std::abs(colour_k[1] - intrinsics_.fy) < 1e-4 &&
                        std::abs(colour_k[2] - intrinsics_.cx) < 1e-4 &&
                        std::abs(colour_k[3] - intrinsics_.cy) < 1e-4;
    const bool identity = std::all_of(extrinsic.begin(), extrinsic.end(),
                                      [](double v) { return std::abs(v) < 1e-9; });
    if (same_k && identity) return;
    std::string camera, pose;
    for (double v : colour_k) camera += (camera.empty() ? "" : ",") + shortest(v);
    for (double v : extrinsic) pose += (pose.empty() ? "" : ",") + shortest(v);
    colour_settings_ = {{"colour_camera", camera}, {"colour_extrinsic", pose}};
  }

  std::string colour_what(size_t i) const {
    std::ostringstream what;
    what << kind_ << " '" << bag_->path() << "', topic '" << colour_topic_ << "', message " << i
         << " (" << colour_[i].time_ns * 1e-9 << " s)";
    return what.str();
  }

  /// The camera's stamp of colour message `i` (cached: pairing walks the list in order).
  double colour_stamp_s(size_t i) {
    if (std::isnan(colour_stamps_[i])) {
      const BagMessage& m = colour_[i];
      if (!colour_metadata_.empty()) {
        colour_stamps_[i] =
            camera_stamp_s(m, colour_metadata_topic_, colour_metadata_, colour_what(i));
      } else {
        const double stamp_s =
            decode_stamp_s(bag_->read(m, colour_topic_), bag_->encoding(), colour_what(i));
        colour_stamps_[i] = stamp_s > 0 ? stamp_s : m.time_ns * 1e-9;
      }
    }
    return colour_stamps_[i];
  }

  /// The colour image nearest the frame's stamp. Both streams run forward in time, so a cursor
  /// walks the colour stream once.
  void read_colour(Frame& frame) {
    const auto gap_s = [&](size_t i) { return std::abs(colour_stamp_s(i) - frame.stamp_s); };
    while (colour_cursor_ + 1 < colour_.size() &&
           gap_s(colour_cursor_ + 1) <= gap_s(colour_cursor_)) {
      ++colour_cursor_;
    }
    KFX_CHECK(gap_s(colour_cursor_) <= kMaxColourGapS,
              frame.source << ": no colour image within " << kMaxColourGapS << " s on topic '"
                           << colour_topic_ << "' (nearest " << gap_s(colour_cursor_)
                           << " s away)");
    const std::string what = colour_what(colour_cursor_);
    const RosImage colour = read_image(colour_topic_, colour_[colour_cursor_], what);
    frame.rgb = colour_image_rgb(colour, width_px_, height_px_, what);
  }

  std::unique_ptr<BagContainer> bag_;
  std::string kind_;
  bool realsense_ = false;
  std::string depth_topic_, depth_info_topic_, colour_topic_, metadata_topic_;
  std::map<std::string, std::string> types_;  ///< image and string topics' types
  std::vector<BagMessage> metadata_;
  std::string colour_metadata_topic_;
  std::vector<BagMessage> colour_metadata_;
  std::vector<double> colour_stamps_;  ///< camera stamps of colour_, NaN until read
  size_t colour_cursor_ = 0;
  std::vector<BagMessage> depth_, colour_;
  int width_px_ = 0, height_px_ = 0;
  Intrinsics intrinsics_;
  LensDistortion distortion_;
  double metres_per_unit_ = 0.001;
  std::vector<std::pair<std::string, std::string>> colour_settings_;
  size_t next_index_ = 0;
};

}  // namespace

BagTopics parse_bag_topics(const std::string& query, const std::string& input) {
  BagTopics topics;
  std::stringstream stream(query);
  std::string pair;
  while (std::getline(stream, pair, '&')) {
    const auto equals = pair.find('=');
    KFX_CHECK(equals != std::string::npos && equals > 0 && equals + 1 < pair.size(),
              "input '" << input << "': '" << pair
                        << "' is not key=value (keys: depth, colour, depth_info, colour_info)");
    const std::string key = pair.substr(0, equals), value = pair.substr(equals + 1);
    if (key == "depth") {
      topics.depth = value;
    } else if (key == "colour" || key == "color") {
      if (value == "none") {
        topics.no_colour = true;
      } else {
        topics.colour = value;
      }
    } else if (key == "depth_info") {
      topics.depth_info = value;
    } else if (key == "colour_info" || key == "color_info") {
      topics.colour_info = value;
    } else {
      KFX_FAIL("input '" << input << "': unknown key '" << key
                         << "' (keys: depth, colour, depth_info, colour_info)");
    }
  }
  return topics;
}

std::unique_ptr<Reader> open_bag_reader(std::unique_ptr<BagContainer> bag, const BagTopics& topics,
                                        const ReaderOptions& options) {
  return std::make_unique<BagReader>(std::move(bag), topics, options);
}

bool is_ros2_bag_folder(const std::string& path) {
  std::error_code error;
  if (!fs::is_directory(path, error)) return false;
  std::ifstream metadata(fs::path(path) / "metadata.yaml");
  std::string line;
  while (std::getline(metadata, line)) {
    if (line.find("rosbag2_bagfile_information") != std::string::npos) return true;
  }
  // Without rosbag2's metadata: a lone .db3 or .mcap, in a folder that is no dataset's.
  for (const char* listing : {"associations.txt", "depth.txt", "rgb.txt", "groundtruth.txt"}) {
    if (fs::exists(fs::path(path) / listing, error)) return false;
  }
  for (const auto& entry : fs::directory_iterator(path, error)) {
    const auto extension = entry.path().extension();
    if (extension == ".db3" || extension == ".mcap") return true;
  }
  return false;
}

}  // namespace kfx::io
