/// OpenNI2 devices as inputs (`openni2:` for the first device, `openni2:URI` for one): a depth
/// camera OpenNI2 reaches through its drivers (PrimeSense PS1080: Xtion, Carmine; Kinect v1
/// through libfreenect's driver; Orbbec's), or an .oni recording that OpenNI2 plays as a device
/// at its recorded pace, standing in for the camera. Frames are read as the device delivers
/// them. OpenNI2 holds only each stream's newest frame, so a reader slower than the camera
/// misses frames (the frame numbers show the gaps) instead of falling ever further behind.

#include <algorithm>
#include <chrono>
#include <memory>
#include <sstream>
#include <string>
#include <thread>

#include "core/platform.hpp"
#include "io/formats.hpp"
#include "io/openni2_frames.hpp"

namespace kfx::io {

namespace {

/// What follows `openni2:`: the device, and the options after '?'.
struct DeviceChoice {
  std::string uri;        ///< "" = the first device (OpenNI2's ANY_DEVICE)
  bool real_time = true;  ///< a recording plays at its recorded pace (off: frame by frame)
  bool colour = true;     ///< read colour when the device has it
};

bool parse_switch(const std::string& value, const std::string& key, const std::string& input) {
  if (value == "on" || value == "true" || value == "1") return true;
  if (value == "off" || value == "false" || value == "0") return false;
  KFX_FAIL("cannot open input '" << input << "': " << key << "=" << value
                                 << " is neither on nor off");
}

DeviceChoice parse_choice(const std::string& input) {
  DeviceChoice choice;
  std::string rest = input.substr(std::string(kOpenNI2Prefix).size());
  const auto mark = rest.rfind('?');
  if (mark != std::string::npos && rest.find('=', mark) != std::string::npos) {
    std::istringstream options(rest.substr(mark + 1));
    rest.resize(mark);
    std::string option;
    while (std::getline(options, option, '&')) {
      const auto equals = option.find('=');
      const std::string key = option.substr(0, equals);
      const std::string value = equals == std::string::npos ? "" : option.substr(equals + 1);
      if (key == "real_time") {
        choice.real_time = parse_switch(value, key, input);
      } else if (key == "colour" || key == "color") {
        choice.colour = parse_switch(value, key, input);
      } else {
        KFX_FAIL("cannot open input '" << input << "': unknown option '" << key
                                       << "' (an OpenNI2 device takes real_time=on|off and "
                                          "colour=on|off)");
      }
    }
  }
  choice.uri = rest;
  return choice;
}

#if KFX_HAVE_OPENNI2

using openni2::last_error;

/// How long the first frame may take: a camera starts its streams, a player opens its file.
constexpr int kFirstFrameTimeoutMs = 5000;
/// How long a running camera may go without a depth frame before it counts as stalled (a
/// camera unplugged).
constexpr int kStallTimeoutMs = 2000;
/// A recording played at its pace has ended when its player falls silent this long (its last
/// frames came while the reader was busy).
constexpr int kPlayerSilentMs = 1000;
/// Long enough for a player to finish handing over a frame (microseconds of work, but its
/// thread may wait for a core on a busy machine).
constexpr std::chrono::milliseconds kPlayerSettleTime{100};

/// The devices OpenNI2 finds, for a message: "none" or "URI (name), ...".
std::string devices_found() {
  openni::Array<openni::DeviceInfo> devices;
  openni::OpenNI::enumerateDevices(&devices);
  if (devices.getSize() == 0) return "none";
  std::ostringstream text;
  for (int i = 0; i < devices.getSize(); ++i) {
    text << (i ? ", " : "") << "'" << devices[i].getUri() << "' (" << devices[i].getVendor() << " "
         << devices[i].getName() << ")";
  }
  return text.str();
}

/// The video mode kfx asks a camera's sensor for: 640×480 at 30 Hz (depth in millimetres,
/// colour RGB888) where it lists that; else `fallback` (its current mode) when kfx reads that
/// one, else the first listed mode kfx reads, else `fallback` (the caller's checks then say
/// what kfx cannot read).
openni::VideoMode choose_mode(const openni::SensorInfo& sensor, bool depth,
                              const openni::VideoMode& fallback) {
  const auto usable = [depth](const openni::VideoMode& mode) {
    return depth ? openni2::is_read_depth_format(mode.getPixelFormat())
                 : mode.getPixelFormat() == openni::PIXEL_FORMAT_RGB888;
  };
  const openni::Array<openni::VideoMode>& modes = sensor.getSupportedVideoModes();
  for (int i = 0; i < modes.getSize(); ++i) {
    const openni::VideoMode& mode = modes[i];
    if (usable(mode) && mode.getResolutionX() == 640 && mode.getResolutionY() == 480 &&
        mode.getFps() == 30 &&
        (!depth || mode.getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_1_MM)) {
      return mode;
    }
  }
  if (usable(fallback)) return fallback;
  for (int i = 0; i < modes.getSize(); ++i) {
    if (usable(modes[i])) return modes[i];
  }
  return fallback;
}

class OpenNI2DeviceReader : public Reader {
 public:
  OpenNI2DeviceReader(const std::string& input, DeviceChoice choice)
      : input_(input), choice_(std::move(choice)) {
    // OpenNI2's threads, started from here on, take no signal meant for the process.
    const openni2::SignalsBlocked signals_blocked;
    what_ =
        choice_.uri.empty() ? "the first OpenNI2 device" : "OpenNI2 device '" + choice_.uri + "'";
    KFX_CHECK(openni::OpenNI::initialize() == openni::STATUS_OK,
              "cannot open " << what_ << ": OpenNI2 did not start (" << last_error() << ")");
    if (device_.open(choice_.uri.empty() ? openni::ANY_DEVICE : choice_.uri.c_str()) !=
        openni::STATUS_OK) {
      const std::string reason = last_error();
      KFX_FAIL("cannot open " << what_ << " (input '" << input_ << "'): "
                              << (choice_.uri.empty() ? "no device found" : "not found") << " ("
                              << reason << "); OpenNI2 finds these devices: " << devices_found()
                              << "; a URI may also be an .oni recording's path");
    }
    playback_ = device_.getPlaybackControl();
    if (!playback_) {
      name_ = std::string(device_.getDeviceInfo().getVendor()) + " " +
              device_.getDeviceInfo().getName() + " at '" + device_.getDeviceInfo().getUri() + "'";
    }
    KFX_CHECK(device_.hasSensor(openni::SENSOR_DEPTH) &&
                  depth_.create(device_, openni::SENSOR_DEPTH) == openni::STATUS_OK,
              what_ << " has no depth stream (" << last_error() << ")");
    if (!playback_) {
      // A camera: the mode kfx reads (a player's mode is the recording's and cannot change).
      const openni::VideoMode mode =
          choose_mode(depth_.getSensorInfo(), true, depth_.getVideoMode());
      if (depth_.setVideoMode(mode) != openni::STATUS_OK) {
        // Keep the camera's own mode; the checks below say if kfx cannot read it.
      }
    }
    depth_mode_ = openni2::read_depth_mode(depth_, what_);
    if (playback_) recorded_frames_ = playback_->getNumberOfFrames(depth_);
    if (choice_.colour && device_.hasSensor(openni::SENSOR_COLOR) &&
        colour_.create(device_, openni::SENSOR_COLOR) == openni::STATUS_OK) {
      open_colour();
    }
    if (playback_) {
      playback_->setRepeatEnabled(false);
      // At the recorded pace the player is the camera (frames come whether read or not);
      // otherwise each comes when asked for, none missed.
      playback_->setSpeed(choice_.real_time ? 1.0f : -1.0f);
    }
    openni2::start_streams(depth_, has_colour_ ? &colour_ : nullptr, what_);
  }

  ~OpenNI2DeviceReader() override {
    if (playback_) {
      // A player closed at once after its reader stopped crashed in libOniFile, in its own
      // thread handing a frame over (kfx live stopped mid-recording on a busy machine: about
      // one stop in two). Put frame by frame, it hands over none unasked, and given a moment
      // to finish the one it may be handing over, it did not crash in 16 stops.
      playback_->setSpeed(-1.0f);
      std::this_thread::sleep_for(kPlayerSettleTime);
    }
    // Streams stopped, then the device closed (ending a player's thread, which walks its
    // streams unlocked), then the streams destroyed.
    depth_.stop();
    if (has_colour_) colour_.stop();
    device_.close();
    depth_.destroy();
    colour_.destroy();
  }

  ReadResult next(Frame& frame) override {
    // A recording's frames are numbered one after another: the last one read was its last.
    if (playback_ && !first_ && index_of(last_number_) + 1 >= recorded_frames_) {
      return {ReadStatus::kEnd, ""};
    }
    openni::VideoFrameRef depth;
    const int timeout_ms = first_ ? kFirstFrameTimeoutMs : silent_timeout_ms();
    if (!wait(depth_, timeout_ms)) {
      // A recording at its pace whose player fell silent has ended: its last frames came
      // while the caller was busy. Frame by frame, it ends early only when it is truncated.
      if (playback_ && choice_.real_time && !first_) return {ReadStatus::kEnd, ""};
      KFX_FAIL(what_ << ": no depth frame " << (first_ ? "came" : "after frame ")
                     << (first_ ? "" : std::to_string(index_of(last_number_))) << " within "
                     << timeout_ms << " ms ("
                     << (playback_ ? "a truncated or corrupt recording?"
                                   : "the camera stopped or was unplugged?")
                     << "): " << last_error());
    }
    KFX_CHECK(depth_.readFrame(&depth) == openni::STATUS_OK && depth.isValid(),
              what_ << ": a depth frame could not be read: " << last_error());
    const int number = depth.getFrameIndex();
    if (first_) first_number_ = number;
    first_ = false;
    last_number_ = number;
    const int index = index_of(number);
    std::ostringstream where;
    where << what_ << " frame " << index;
    if (depth.getWidth() != depth_mode_.width_px || depth.getHeight() != depth_mode_.height_px ||
        depth.getDataSize() < depth_mode_.width_px * depth_mode_.height_px * 2) {
      std::ostringstream message;
      message << "bad frame from " << where.str() << ": depth of " << depth.getDataSize()
              << " bytes, " << depth.getWidth() << "x" << depth.getHeight() << " where "
              << depth_mode_.width_px << "x" << depth_mode_.height_px << " was expected";
      return {ReadStatus::kBadFrame, message.str()};
    }
    openni2::copy_depth_mm(depth, depth_mode_.format, depth_mode_.width_px, depth_mode_.height_px,
                           frame.depth_mm);
    frame.rgb = HostImage<Rgb8>();
    if (has_colour_) {
      read_colour(static_cast<double>(depth.getTimestamp()) * 1e-6, index);
      if (colour_.isValid() && !latest_colour_.empty()) frame.rgb = latest_colour_;
    }
    frame.stamp_s = static_cast<double>(depth.getTimestamp()) * 1e-6;
    frame.index = index;
    frame.source = where.str();
    return {};
  }

  int width_px() const override { return depth_mode_.width_px; }
  int height_px() const override { return depth_mode_.height_px; }
  /// Known only for a recording read frame by frame: at its pace, or from a camera, how many
  /// frames arrive depends on how fast they are read.
  int frame_count() const override {
    return playback_ && !choice_.real_time ? recorded_frames_ : -1;
  }
  std::optional<Intrinsics> default_intrinsics() const override { return depth_mode_.intrinsics; }
  std::string intrinsics_source() const override {
    std::ostringstream text;
    text << (playback_ ? "the recording's" : "the device's") << " field of view ("
         << depth_mode_.hfov_rad << " x " << depth_mode_.vfov_rad
         << " rad), as OpenNI2 maps pixels to points";
    return text.str();
  }
  bool has_colour() const override { return has_colour_; }
  std::vector<StampedPose> ground_truth() const override { return {}; }
  std::string description() const override {
    std::ostringstream text;
    if (playback_) {
      text << "OpenNI2 recording '" << choice_.uri << "' played as a device "
           << (choice_.real_time ? "at its recorded pace" : "frame by frame") << " ("
           << recorded_frames_ << " frames, ";
    } else {
      text << "OpenNI2 device " << name_ << " (";
    }
    text << depth_mode_.width_px << "x" << depth_mode_.height_px << " at " << depth_mode_.fps
         << " Hz"
         << (!has_colour_  ? ", depth only"
             : registered_ ? ", colour registered by the device"
             : playback_   ? ", colour"
                           : ", colour taken as registered")
         << ")";
    return text.str();
  }

 private:
  /// Opens the colour stream where kfx can read it alongside the depth: RGB888 at the depth's
  /// size, registered to the depth where the device can register it.
  void open_colour() {
    if (!playback_) {
      const openni::VideoMode mode =
          choose_mode(colour_.getSensorInfo(), false, colour_.getVideoMode());
      if (colour_.setVideoMode(mode) != openni::STATUS_OK) {
        // Keep the camera's own mode; the checks below say if kfx cannot read it.
      }
      // The device maps its depth into the colour camera's view (PS1080 in hardware), and
      // pairs the two streams' frames, where it can.
      if (device_.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR)) {
        registered_ = device_.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) ==
                      openni::STATUS_OK;
      }
      device_.setDepthColorSyncEnabled(true);
    }
    openni2::check_colour_mode(colour_, depth_mode_.width_px, depth_mode_.height_px, what_,
                               "'?colour=off' reads depth only");
    has_colour_ = !playback_ || playback_->getNumberOfFrames(colour_) > 0;
    if (!has_colour_) colour_.destroy();
  }

  /// Takes the colour frame for a depth frame stamped `stamp_s`: the newest colour frame, waiting
  /// (up to a frame's time) for one that is not older than the depth by half a frame. Frame by
  /// frame the recording's colour frame comes right after its depth frame.
  void read_colour(double stamp_s, int index) {
    const double period_s = 1.0 / (depth_mode_.fps > 0 ? depth_mode_.fps : 30);
    const bool paced = !playback_ || choice_.real_time;
    const int budget_ms = latest_colour_.empty() || !paced
                              ? kFirstFrameTimeoutMs
                              : static_cast<int>(1000.0 * period_s) + 1;
    const auto start = std::chrono::steady_clock::now();
    while (true) {
      const int spent_ms = static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(
                                                std::chrono::steady_clock::now() - start)
                                                .count());
      const int left_ms = std::max(0, budget_ms - spent_ms);
      openni::VideoFrameRef colour;
      if (wait(colour_, left_ms) && colour_.readFrame(&colour) == openni::STATUS_OK &&
          colour.isValid() && colour.getWidth() == depth_mode_.width_px &&
          colour.getHeight() == depth_mode_.height_px &&
          colour.getDataSize() >= depth_mode_.width_px * depth_mode_.height_px * 3) {
        openni2::copy_rgb(colour, depth_mode_.width_px, depth_mode_.height_px, latest_colour_);
        colour_stamp_s_ = static_cast<double>(colour.getTimestamp()) * 1e-6;
        if (!paced || colour_stamp_s_ >= stamp_s - period_s / 2) return;
      }
      if (left_ms == 0) break;
    }
    KFX_CHECK(!latest_colour_.empty(), what_ << ": no colour frame came for depth frame " << index
                                             << " within " << budget_ms << " ms: " << last_error()
                                             << " ('?colour=off' reads depth only)");
  }

  /// Waits up to `timeout_ms` for a frame of `stream`; false when none came.
  static bool wait(openni::VideoStream& stream, int timeout_ms) {
    openni::VideoStream* streams[] = {&stream};
    int ready = -1;
    return openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms) == openni::STATUS_OK;
  }

  int silent_timeout_ms() const {
    return playback_ && choice_.real_time ? kPlayerSilentMs : kStallTimeoutMs;
  }

  /// A frame's index: its device number counted from the first frame read (a recording's
  /// frames are numbered from 1, a camera's from wherever it was when opened).
  int index_of(int number) const { return number - first_number_; }

  std::string input_, what_, name_;
  DeviceChoice choice_;
  // Declared before the device, so destroyed after it also when the constructor throws (see
  // the destructor).
  openni::VideoStream depth_, colour_;
  openni::Device device_;
  openni::PlaybackControl* playback_ = nullptr;
  openni2::DepthStreamMode depth_mode_;  ///< size, format and camera of the depth stream
  HostImage<Rgb8> latest_colour_;
  double colour_stamp_s_ = 0.0;
  int recorded_frames_ = 0;
  int first_number_ = 0, last_number_ = 0;
  bool first_ = true, has_colour_ = false, registered_ = false;
};

#endif

}  // namespace

bool openni2_built() {
#if KFX_HAVE_OPENNI2
  return true;
#else
  return false;
#endif
}

std::unique_ptr<Reader> open_openni2_device(const std::string& input) {
  DeviceChoice choice = parse_choice(input);
#if KFX_HAVE_OPENNI2
  return std::make_unique<OpenNI2DeviceReader>(input, std::move(choice));
#else
  KFX_FAIL("cannot open input '" << input
                                 << "': this kfx was built without OpenNI2, which reaches "
                                    "OpenNI2 devices; install Debian's libopenni2-dev and "
                                    "rebuild");
#endif
}

}  // namespace kfx::io
