#pragma once
/// What the API's implementation shares with the in-tree clients (the CLI, tests): the
/// internal objects behind the public types. Never included by a public header.

#include <vector>

#include "core/camera.hpp"
#include "io/reader.hpp"
#include "kfx/reconstruction.hpp"
#include "kfx/sequence.hpp"
#include "kfx/settings.hpp"
#include "pipeline/config.hpp"
#include "pipeline/frame_diagnostics.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx {
namespace api {

/// The configuration `settings` describes (preset, then overrides in order); not validated.
PipelineConfig make_config(const Settings& settings);

/// A view of a frame a reader read (its depth is packed millimetres: no copy when submitted).
FrameView frame_view(const io::Frame& frame);

/// A public pose from a matrix, and back.
Pose to_pose(const Mat4f& m);
Mat4f to_mat4f(const Pose& pose);

}  // namespace api

/// The reader behind a Sequence.
struct SequenceAccess {
  static io::Reader& reader(Sequence& sequence);
  static const io::Reader& reader(const Sequence& sequence);
};

/// The pipeline behind a Reconstruction, for the CLI's run outputs (per-stage times, the
/// SLAMBench log, energy on the backend's device). Frames still go through the Reconstruction.
struct ReconstructionAccess {
  /// A reconstruction whose caller closes loops itself: `kfx run` drives src/loop/'s
  /// OnlineLoopClosure around it (or fuses at given poses, where no loop is closed), so the
  /// setting loop_closure=online is accepted here; the public constructors refuse it.
  static Reconstruction for_caller_closing_loops(const Settings& settings, const Camera& camera);
  static Pipeline& pipeline(Reconstruction& reconstruction);
  /// The internal report of the last collected frame (stage times, renders made).
  static const FrameReport& last_report(const Reconstruction& reconstruction);
  /// Submits a frame a reader read (with its colour image, when it has one).
  static void submit(Reconstruction& reconstruction, const io::Frame& frame);
  /// Submits it at a given pose: not tracked, integrated there (Pipeline::submit_at_pose, whose
  /// `raycast_view` this is); frames may be in flight.
  static void submit_at_pose(Reconstruction& reconstruction, const io::Frame& frame,
                             const Mat4f& T_world_cam, bool raycast_view = true);
  /// The volume and depth warnings counted so far, per cause (kfx run's stats.json).
  static const FrameDiagnostics& diagnostics(const Reconstruction& reconstruction);
  /// Turns the renders of Pipeline::set_rendering on; frames that render are collected at once.
  static void set_rendering(Reconstruction& reconstruction, bool on);
};

}  // namespace kfx
