#pragma once
/// Inputs as sequences of frames: every input the CLI reads (TUM RGB-D and ICL-NUIM folders,
/// ICL-NUIM's native form, SLAMBench `.raw`, `synthetic[:key=value,...]`).

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "kfx/camera.hpp"
#include "kfx/frame.hpp"
#include "kfx/model.hpp"

namespace kfx {

/// True when this kfx was built with OpenNI2 (Debian's libopenni2-dev), which reads `.oni`
/// recordings and OpenNI2 devices (`openni2:` inputs); false where those inputs say it was not.
bool has_openni2();

/// One frame as a sequence read it. The depth is in millimetres (uint16, 0 = no measurement).
struct SequenceFrame {
  int index = 0;         ///< position in the sequence, from 0
  double stamp_s = 0.0;  ///< the dataset's time stamp
  int width_px = 0;
  int height_px = 0;
  std::vector<uint16_t> depth_mm;  ///< width × height, row-major
  std::vector<uint8_t> colour;     ///< r g b per pixel; empty when the input has no colour
  std::string source;              ///< the file (and frame) it came from, for messages
  /// A view of this frame (valid while the frame is neither changed nor destroyed).
  FrameView view() const;
};

/// A ground-truth pose: camera to world, as the dataset gives it.
struct StampedPose {
  double stamp_s = 0.0;
  std::array<double, 3> t{};  ///< translation, metres
  std::array<double, 4> q{};  ///< unit quaternion x y z w
};

/// Outcome of Sequence::next().
enum class ReadStatus {
  kOk,        ///< a frame was read
  kEnd,       ///< no more frames
  kBadFrame,  ///< this frame is bad (message() names file, frame and problem); later may be fine
};

/// A sequence of frames from a file, a folder or the synthetic scene, read in order.
class Sequence {
 public:
  /// Opens `input`. `depth_scale_per_m`: PNG depth units per metre (0: the format's, 5000 for
  /// TUM and ICL-NUIM). `ground_truth_path`: a TUM trajectory to use instead of the one found
  /// beside the input ("" = auto). Throws kfx::Error naming the input and what is wrong.
  explicit Sequence(const std::string& input, double depth_scale_per_m = 0.0,
                    const std::string& ground_truth_path = "");
  ~Sequence();
  Sequence(Sequence&&) noexcept;
  Sequence& operator=(Sequence&&) noexcept;

  /// Reads the next frame into `frame` (its buffers are reused). kBadFrame: message() says why.
  /// Malformed input that makes the whole source unusable throws kfx::Error.
  ReadStatus next(SequenceFrame& frame);
  /// The problem of the last kBadFrame.
  const std::string& message() const;

  const std::string& input() const;
  int width_px() const;
  int height_px() const;
  /// Number of frames when known, else −1.
  int frame_count() const;
  /// True when the frames carry a colour image (registered to the depth image).
  bool has_colour() const;
  /// The camera the format defines (intrinsics at input size, the lens where known), if any.
  std::optional<Camera> camera() const;
  /// Where camera() comes from ("TUM freiburg 1 camera, named by the folder ..."); "" if none.
  std::string camera_source() const;
  /// Ground-truth poses (camera to world), empty when there are none.
  std::vector<StampedPose> ground_truth() const;
  /// One line describing the source ("TUM RGB-D folder X (798 frames)").
  std::string description() const;
  /// Settings (key, value) that suit this input, applied unless the user set those keys (e.g.
  /// the synthetic scene's volume size).
  std::vector<std::pair<std::string, std::string>> recommended_settings() const;

 private:
  friend struct SequenceAccess;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kfx
