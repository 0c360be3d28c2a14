#pragma once
/// Internal to the OpenNI2 readers (oni_reader.cpp: recordings frame by frame;
/// openni2_device.cpp: devices, live): what both make of OpenNI2's streams and frames. Declared
/// only where kfx is built with OpenNI2 (KFX_HAVE_OPENNI2).

#if KFX_HAVE_OPENNI2
#include <OpenNI.h>
#include <signal.h>

#include <string>

#include "core/camera.hpp"
#include "core/image.hpp"

namespace kfx::io::openni2 {

/// While alive, the calling thread takes no asynchronous signal (SIGINT, SIGTERM, ...), so the
/// threads OpenNI2 starts meanwhile (its drivers', a player's) never take one either: they
/// inherit the mask. A player woken by a signal meant for the process (Ctrl-C) crashes in
/// libOniFile; the signal goes to a thread that handles it instead.
class SignalsBlocked {
 public:
  SignalsBlocked();
  ~SignalsBlocked();
  SignalsBlocked(const SignalsBlocked&) = delete;
  SignalsBlocked& operator=(const SignalsBlocked&) = delete;

 private:
  sigset_t previous_;
};

/// OpenNI2's last error, trimmed, for messages ("no reason given" when it gave none).
std::string last_error();

/// The pinhole camera OpenNI2 itself assumes for `stream` (its CoordinateConverter maps pixels
/// to points so): fx = width / (2 tan(hfov/2)), fy from the vertical field of view, the optical
/// centre at the image's centre, no distortion. Its fields of view (radians) go to `hfov_rad`
/// and `vfov_rad`. Throws, naming `what` ("OpenNI2 recording 'x.oni'"), when the stream gives
/// no usable field of view.
Intrinsics intrinsics_from_field_of_view(const openni::VideoStream& stream, int width_px,
                                         int height_px, const std::string& what, float* hfov_rad,
                                         float* vfov_rad);

/// True for the depth pixel formats kfx reads (1 mm and 100 µm units).
bool is_read_depth_format(openni::PixelFormat format);

/// A depth stream's video mode, as kfx reads it.
struct DepthStreamMode {
  int width_px = 0, height_px = 0;
  int fps = 0;
  openni::PixelFormat format = openni::PIXEL_FORMAT_DEPTH_1_MM;
  Intrinsics intrinsics;  ///< intrinsics_from_field_of_view()
  float hfov_rad = 0.0f, vfov_rad = 0.0f;
};

/// The video mode `depth` delivers, checked: an image size, a depth format kfx reads, a field
/// of view. Throws naming `what` ("OpenNI2 recording 'x.oni'") and what is wrong.
DepthStreamMode read_depth_mode(const openni::VideoStream& depth, const std::string& what);

/// Checks that `colour` delivers what kfx reads beside a depth of `width_px` × `height_px`:
/// RGB888 at the same size (registered colour). Throws naming `what`; `colour_off_hint`, when
/// not empty, says how to read the depth alone.
void check_colour_mode(const openni::VideoStream& colour, int width_px, int height_px,
                       const std::string& what, const std::string& colour_off_hint);

/// Starts `depth`, then `colour` when given; throws naming `what` and OpenNI2's reason.
void start_streams(openni::VideoStream& depth, openni::VideoStream* colour,
                   const std::string& what);

/// Copies a depth frame of `width_px` × `height_px` into `out` in millimetres (100 µm units to
/// the nearest millimetre). The caller checked the frame's size.
void copy_depth_mm(const openni::VideoFrameRef& frame, openni::PixelFormat format, int width_px,
                   int height_px, HostImage<uint16_t>& out);

/// Copies an RGB888 frame of `width_px` × `height_px` into `out`. The caller checked its size.
void copy_rgb(const openni::VideoFrameRef& frame, int width_px, int height_px,
              HostImage<Rgb8>& out);

}  // namespace kfx::io::openni2
#endif
