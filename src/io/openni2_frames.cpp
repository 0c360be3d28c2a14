/// What the OpenNI2 readers share: OpenNI2's errors, its camera model, its pixels.

#include "io/openni2_frames.hpp"

#if KFX_HAVE_OPENNI2
#include <pthread.h>

#include <cmath>

#include "core/platform.hpp"

namespace kfx::io::openni2 {

SignalsBlocked::SignalsBlocked() {
  sigset_t all;
  sigfillset(&all);
  pthread_sigmask(SIG_BLOCK, &all, &previous_);
}

SignalsBlocked::~SignalsBlocked() { pthread_sigmask(SIG_SETMASK, &previous_, nullptr); }

std::string last_error() {
  const char* text = openni::OpenNI::getExtendedError();
  std::string error = text ? text : "";
  while (!error.empty() && (error.back() == '\n' || error.back() == ' ')) error.pop_back();
  while (!error.empty() && (error.front() == '\t' || error.front() == ' ')) error.erase(0, 1);
  return error.empty() ? "no reason given" : error;
}

Intrinsics intrinsics_from_field_of_view(const openni::VideoStream& stream, int width_px,
                                         int height_px, const std::string& what, float* hfov_rad,
                                         float* vfov_rad) {
  const float hfov = stream.getHorizontalFieldOfView(), vfov = stream.getVerticalFieldOfView();
  KFX_CHECK(std::isfinite(hfov) && std::isfinite(vfov) && hfov > 0.0f && vfov > 0.0f &&
                hfov < 3.1f && vfov < 3.1f,
            what << ": intrinsics missing: its depth stream gives no field of view (" << hfov
                 << " x " << vfov << " rad)");
  *hfov_rad = hfov;
  *vfov_rad = vfov;
  return Intrinsics{static_cast<float>(width_px / (2.0 * std::tan(hfov / 2.0))),
                    static_cast<float>(height_px / (2.0 * std::tan(vfov / 2.0))), width_px / 2.0f,
                    height_px / 2.0f};
}

bool is_read_depth_format(openni::PixelFormat format) {
  return format == openni::PIXEL_FORMAT_DEPTH_1_MM || format == openni::PIXEL_FORMAT_DEPTH_100_UM;
}

DepthStreamMode read_depth_mode(const openni::VideoStream& depth, const std::string& what) {
  const openni::VideoMode mode = depth.getVideoMode();
  DepthStreamMode out;
  out.width_px = mode.getResolutionX();
  out.height_px = mode.getResolutionY();
  out.fps = mode.getFps();
  out.format = mode.getPixelFormat();
  KFX_CHECK(out.width_px > 0 && out.height_px > 0, what << ": its depth stream has no image size");
  KFX_CHECK(is_read_depth_format(out.format), what << ": depth in pixel format "
                                                   << static_cast<int>(out.format)
                                                   << " is not read (millimetres and 100 µm are)");
  // The camera from the field of view, as OpenNI2 itself maps pixels to points.
  out.intrinsics = intrinsics_from_field_of_view(depth, out.width_px, out.height_px, what,
                                                 &out.hfov_rad, &out.vfov_rad);
  return out;
}

void check_colour_mode(const openni::VideoStream& colour, int width_px, int height_px,
                       const std::string& what, const std::string& colour_off_hint) {
  const openni::VideoMode mode = colour.getVideoMode();
  KFX_CHECK(mode.getPixelFormat() == openni::PIXEL_FORMAT_RGB888,
            what << ": colour in pixel format " << static_cast<int>(mode.getPixelFormat())
                 << " is not read (RGB888 and JPEG are)"
                 << (colour_off_hint.empty() ? "" : "; " + colour_off_hint));
  KFX_CHECK(mode.getResolutionX() == width_px && mode.getResolutionY() == height_px,
            what << ": colour " << mode.getResolutionX() << "x" << mode.getResolutionY()
                 << " is not the depth's size " << width_px << "x" << height_px
                 << "; kfx reads registered colour only"
                 << (colour_off_hint.empty() ? "" : " (" + colour_off_hint + ")"));
}

void start_streams(openni::VideoStream& depth, openni::VideoStream* colour,
                   const std::string& what) {
  KFX_CHECK(depth.start() == openni::STATUS_OK,
            what << ": its depth stream does not start (" << last_error() << ")");
  if (colour != nullptr) {
    KFX_CHECK(colour->start() == openni::STATUS_OK,
              what << ": its colour stream does not start (" << last_error() << ")");
  }
}

void copy_depth_mm(const openni::VideoFrameRef& frame, openni::PixelFormat format, int width_px,
                   int height_px, HostImage<uint16_t>& out) {
  out = HostImage<uint16_t>(width_px, height_px);
  const auto* pixels = static_cast<const uint16_t*>(frame.getData());
  const int stride = frame.getStrideInBytes() / 2;
  const bool tenths = format == openni::PIXEL_FORMAT_DEPTH_100_UM;
  for (int y = 0; y < height_px; ++y) {
    for (int x = 0; x < width_px; ++x) {
      const uint16_t value = pixels[y * stride + x];
      // 100 µm units: to the nearest millimetre.
      out(x, y) = tenths ? static_cast<uint16_t>((value + 5) / 10) : value;
    }
  }
}

void copy_rgb(const openni::VideoFrameRef& frame, int width_px, int height_px,
              HostImage<Rgb8>& out) {
  out = HostImage<Rgb8>(width_px, height_px);
  const auto* rgb = static_cast<const uint8_t*>(frame.getData());
  const int stride = frame.getStrideInBytes();
  for (int y = 0; y < height_px; ++y) {
    for (int x = 0; x < width_px; ++x) {
      const uint8_t* p = rgb + y * stride + 3 * x;
      out(x, y) = Rgb8{p[0], p[1], p[2]};
    }
  }
}

}  // namespace kfx::io::openni2
#endif
