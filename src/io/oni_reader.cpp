/// OpenNI 2 recordings (.oni) through OpenNI 2's own player (Debian's libopenni2: its OniFile
/// driver reads the file and decodes its codecs, the compressed depth and JPEG colour of a
/// camera's recording included). Built only where libopenni2-dev was found; elsewhere an .oni
/// input says kfx was built without it.

#include <filesystem>
#include <memory>
#include <sstream>
#include <string>

#include "core/platform.hpp"
#include "io/formats.hpp"
#include "io/openni2_frames.hpp"

namespace kfx::io {

#if KFX_HAVE_OPENNI2
namespace {

using openni2::last_error;

/// How long a frame the file says it has may take to come: the player reads it from disk and
/// decodes it; longer means the file ends before it (the player then never delivers it).
constexpr int kFrameTimeoutMs = 2000;

class OniReader : public Reader {
 public:
  explicit OniReader(std::string path) : path_(std::move(path)) {
    // OpenNI2's threads, started from here on, take no signal meant for the process (Ctrl-C
    // during kfx run).
    const openni2::SignalsBlocked signals_blocked;
    std::error_code error;
    KFX_CHECK(std::filesystem::is_regular_file(path_, error),
              "cannot open input '" << path_ << "': no such file");
    KFX_CHECK(openni::OpenNI::initialize() == openni::STATUS_OK,
              "cannot open OpenNI2 recording '" << path_ << "': OpenNI2 did not start ("
                                                << last_error() << ")");
    KFX_CHECK(device_.open(path_.c_str()) == openni::STATUS_OK,
              "cannot open OpenNI2 recording '" << path_ << "': " << last_error());
    playback_ = device_.getPlaybackControl();
    KFX_CHECK(playback_ != nullptr,
              "cannot open OpenNI2 recording '" << path_ << "': OpenNI2 opened it as a device");
    KFX_CHECK(device_.hasSensor(openni::SENSOR_DEPTH) &&
                  depth_.create(device_, openni::SENSOR_DEPTH) == openni::STATUS_OK,
              "OpenNI2 recording '" << path_ << "' has no depth stream");
    const std::string what = "OpenNI2 recording '" + path_ + "'";
    depth_mode_ = openni2::read_depth_mode(depth_, what);
    frames_ = playback_->getNumberOfFrames(depth_);
    KFX_CHECK(frames_ > 0, "OpenNI2 recording '" << path_ << "' holds no depth frame");
    if (device_.hasSensor(openni::SENSOR_COLOR) &&
        colour_.create(device_, openni::SENSOR_COLOR) == openni::STATUS_OK) {
      openni2::check_colour_mode(colour_, depth_mode_.width_px, depth_mode_.height_px, what, "");
      has_colour_ = playback_->getNumberOfFrames(colour_) > 0;
      if (!has_colour_) colour_.destroy();
    }
    // Frame by frame, each when it is asked for (no frame is dropped, whatever the pace), once.
    playback_->setSpeed(-1.0f);
    playback_->setRepeatEnabled(false);
    openni2::start_streams(depth_, has_colour_ ? &colour_ : nullptr, what);
  }

  ~OniReader() override {
    // Streams stopped, then the device closed (which ends its player thread), then the streams
    // destroyed: the player thread walks its list of streams unlocked, so destroying one while
    // it runs is a use after free (seen as a crash in libOniFile).
    depth_.stop();
    if (has_colour_) colour_.stop();
    device_.close();
    depth_.destroy();
    if (has_colour_) colour_.destroy();
  }

  ReadResult next(Frame& frame) override {
    if (index_ >= frames_) return {ReadStatus::kEnd, ""};
    const int index = index_++;
    std::ostringstream where;
    where << path_ << " frame " << index;
    openni::VideoFrameRef depth;
    read(depth_, depth, "depth", index);
    const int expected = depth_mode_.width_px * depth_mode_.height_px * 2;
    if (depth.getWidth() != depth_mode_.width_px || depth.getHeight() != depth_mode_.height_px ||
        depth.getDataSize() < expected) {
      std::ostringstream message;
      message << "bad frame in OpenNI2 recording '" << path_ << "', depth frame " << index << ": "
              << depth.getDataSize() << " bytes of " << depth.getWidth() << "x" << depth.getHeight()
              << " where " << expected << " bytes of " << depth_mode_.width_px << "x"
              << depth_mode_.height_px << " were expected";
      return {ReadStatus::kBadFrame, message.str()};
    }
    openni2::copy_depth_mm(depth, depth_mode_.format, depth_mode_.width_px, depth_mode_.height_px,
                           frame.depth_mm);
    frame.rgb = HostImage<Rgb8>();
    if (has_colour_ && index < playback_->getNumberOfFrames(colour_)) {
      openni::VideoFrameRef colour;
      read(colour_, colour, "colour", index);
      if (colour.getWidth() != depth_mode_.width_px ||
          colour.getHeight() != depth_mode_.height_px ||
          colour.getDataSize() < depth_mode_.width_px * depth_mode_.height_px * 3) {
        std::ostringstream message;
        message << "bad frame in OpenNI2 recording '" << path_ << "', colour frame " << index
                << ": " << colour.getDataSize() << " bytes of " << colour.getWidth() << "x"
                << colour.getHeight();
        return {ReadStatus::kBadFrame, message.str()};
      }
      openni2::copy_rgb(colour, depth_mode_.width_px, depth_mode_.height_px, frame.rgb);
    }
    frame.stamp_s = static_cast<double>(depth.getTimestamp()) * 1e-6;
    frame.index = index;
    frame.source = where.str();
    return {};
  }

  int width_px() const override { return depth_mode_.width_px; }
  int height_px() const override { return depth_mode_.height_px; }
  int frame_count() const override { return frames_; }
  std::optional<Intrinsics> default_intrinsics() const override { return depth_mode_.intrinsics; }
  std::string intrinsics_source() const override {
    std::ostringstream text;
    text << "the recording's field of view (" << depth_mode_.hfov_rad << " x "
         << depth_mode_.vfov_rad << " rad)";
    return text.str();
  }
  bool has_colour() const override { return has_colour_; }
  std::vector<StampedPose> ground_truth() const override { return {}; }
  std::string description() const override {
    std::ostringstream text;
    text << "OpenNI2 recording " << path_ << " (" << frames_ << " frames, " << depth_mode_.width_px
         << "x" << depth_mode_.height_px << (has_colour_ ? ", colour" : ", depth only") << ")";
    return text.str();
  }

 private:
  /// The stream's next frame; a recording that ends before the frames it announces is
  /// truncated.
  void read(openni::VideoStream& stream, openni::VideoFrameRef& out, const char* what, int index) {
    openni::VideoStream* streams[] = {&stream};
    int ready = -1;
    KFX_CHECK(openni::OpenNI::waitForAnyStream(streams, 1, &ready, kFrameTimeoutMs) ==
                      openni::STATUS_OK &&
                  stream.readFrame(&out) == openni::STATUS_OK && out.isValid(),
              "OpenNI2 recording '" << path_ << "', " << what << " frame " << index << " of "
                                    << frames_ << ": not delivered (a truncated or corrupt "
                                    << "recording?): " << last_error());
  }

  std::string path_;
  // Declared before the device, so destroyed after it also when the constructor throws (see
  // the destructor).
  openni::VideoStream depth_, colour_;
  openni::Device device_;
  openni::PlaybackControl* playback_ = nullptr;
  openni2::DepthStreamMode depth_mode_;  ///< size, format and camera of the depth stream
  int frames_ = 0, index_ = 0;
  bool has_colour_ = false;
};

}  // namespace
#endif

std::unique_ptr<Reader> open_oni_recording(const std::string& path) {
#if KFX_HAVE_OPENNI2
  return std::make_unique<OniReader>(path);
#else
  KFX_FAIL("cannot open input '" << path
                                 << "': this kfx was built without OpenNI2, which reads .oni "
                                    "recordings; install Debian's libopenni2-dev and rebuild");
#endif
}

}  // namespace kfx::io
