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
