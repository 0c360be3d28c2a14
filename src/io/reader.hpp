#pragma once
/// The reader interface: every input format yields Frames in order, with intrinsics and ground
/// truth where the format has them.

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/camera.hpp"
#include "io/frame.hpp"
#include "io/trajectory.hpp"

namespace kfx::io {

/// Outcome of Reader::next().
enum class ReadStatus {
  kOk,        ///< a frame was read
  kEnd,       ///< no more frames
  kBadFrame,  ///< this frame is bad (message says file, frame and problem); later ones may be fine
};

/// Result of Reader::next(): a status and, for kBadFrame, a message naming file, frame, problem.
struct ReadResult {
  ReadStatus status = ReadStatus::kOk;
  std::string message;
};

/// Options common to all readers.
struct ReaderOptions {
  /// Raw PNG units per metre; 0 = the format's default (TUM and ICL-NUIM PNG: 5000).
  double depth_scale_per_m = 0.0;
  /// Ground-truth file to use instead of the one found in the dataset folder ("" = auto).
  std::string ground_truth_path;
};

/// What a format could not tell from the input and assumed (a TUM-style folder whose name names
/// no TUM camera): wrong guesses spoil a run without a word, so they are said as warnings.
struct InputAssumptions {
  bool intrinsics = false;   ///< default_intrinsics() are generic, not this camera's
  bool depth_scale = false;  ///< the depth scale is the format's default, not one given
  std::string why;           ///< what the input lacks, e.g. "the folder 'x' names no TUM camera"
};

/// A source of depth frames.
class Reader {
 public:
  virtual ~Reader() = default;
  /// Reads the next frame into `frame`. Malformed input that makes the whole source unusable
  /// throws kfx::Error; a single bad frame returns kBadFrame with a clear message.
  virtual ReadResult next(Frame& frame) = 0;
  /// Input image width and height in pixels.
  virtual int width_px() const = 0;
  virtual int height_px() const = 0;
  /// Number of frames when known, else −1.
  virtual int frame_count() const = 0;
  /// The format's intrinsics at input resolution, if it defines them.
  virtual std::optional<Intrinsics> default_intrinsics() const = 0;
  /// Where default_intrinsics() come from and why, for the user ("TUM freiburg 1 camera, named
  /// by the folder 'x'"); "" when there are none.
  virtual std::string intrinsics_source() const { return ""; }
  /// The lens distortion of the camera default_intrinsics() describe (TUM fr1 and fr2: their
  /// published calibration); none when the format's images have none or it is unknown.
  virtual LensDistortion default_distortion() const { return {}; }
  /// True when the camera default_intrinsics() describe is known to have no lens distortion
  /// (rendered images: the synthetic scene, ICL-NUIM; TUM fr3, whose images TUM undistorted),
  /// so none is to be undone; false when the lens is unknown or default_distortion() gives it.
  virtual bool ideal_lens() const { return false; }
  /// Raw depth units per metre the frames are read at (PNG sequences: 5000 by default); 0 where
  /// the format fixes the unit (metres, millimetres) and no scale applies.
  virtual double depth_scale_per_m() const { return 0.0; }
  /// What the format assumed for want of a name or a file saying it (nothing by default).
  virtual InputAssumptions assumptions() const { return {}; }
  /// True when every frame carries a colour image (Frame::rgb); false for depth-only inputs and
  /// for listings whose colour images are all absent (description() then says so).
  virtual bool has_colour() const { return false; }
  /// Ground-truth poses (camera to world), empty when there are none.
  virtual std::vector<StampedPose> ground_truth() const = 0;
  /// Every frame's stamp in seconds, in order, where the format lists them up front (so a
  /// ground truth can be checked before the run); empty when they are known only frame by frame.
  virtual std::vector<double> stamps_s() const { return {}; }
  /// One line describing the source, e.g. "TUM RGB-D folder X (798 frames)".
  virtual std::string description() const = 0;
  /// Pipeline settings (config key, value) that suit this input, applied unless the user set
  /// them; e.g. the synthetic scene's volume size.
  virtual std::vector<std::pair<std::string, std::string>> recommended_settings() const {
    return {};
  }
};

/// Opens `input`: a TUM RGB-D folder, an ICL-NUIM PNG folder, an ICL-NUIM native (POV-Ray)
/// folder, a SLAMBench `.raw` file, a recording (RealSense `.bag`/`.db3`, ROS 1 bag, ROS 2 bag,
/// OpenNI2 `.oni`;
/// topics chosen by `input?depth=/topic&colour=/topic`: docs/cameras.md), an OpenNI2 device
/// (`openni2:` the first, `openni2:URI` one, read as it delivers frames), or
/// `synthetic[:key=value,...]`. Throws kfx::Error naming the
/// path and what is wrong when it cannot be opened or recognised.
std::unique_ptr<Reader> open_reader(const std::string& input, const ReaderOptions& options = {});

/// True when kfx was built with OpenNI2, which reads `.oni` recordings and OpenNI2 devices.
bool openni2_built();

}  // namespace kfx::io
