#pragma once
/// Every warning of a run as stretches of frames, per cause: the frame diagnostics (camera or
/// depth outside the volume, implausible depth, poorly constrained tracking), lost tracking, a
/// full block map, skipped bad frames and divergence from the ground truth. The terminal warns
/// when a stretch begins (a few times per cause); stats.json's `warning_stretches` and the
/// report list every stretch, so the three agree.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace kfx::cli {

/// Frames first_frame…last_frame (the input's numbers) of which `frames` had the cause.
struct WarningStretch {
  std::string cause;  ///< stats.json's name: "lost_tracking", "poorly_constrained_tracking", ...
  int first_frame = 0;
  int last_frame = 0;
  int frames = 0;
};

/// Builds stretches from per-frame observations, frames in order. A stretch ends after
/// `frames_to_end` observed frames without its cause (FrameDiagnostics' rule, so a figure
/// hovering at its bound makes one stretch, as it makes one warning).
class WarningStretches {
 public:
  explicit WarningStretches(int frames_to_end) : frames_to_end_(frames_to_end) {}

  /// Records whether `cause` holds at `frame`; frames must come in increasing order per cause.
  void observe(const std::string& cause, int frame, bool present);

  /// Adds a stretch found otherwise (skipped bad frames, which never reach the pipeline).
  void add(const WarningStretch& stretch) { closed_.push_back(stretch); }

  /// Every stretch so far, ordered by first frame then cause.
  std::vector<WarningStretch> stretches() const;

  /// Stretches as stats.json's `warning_stretches`: [{cause, first_frame, last_frame, frames}].
  nlohmann::json to_json() const;

 private:
  struct Open {
    std::string cause;
    WarningStretch stretch;
    int frames_without = 0;
    bool open = false;
  };
  Open& slot(const std::string& cause);

  int frames_to_end_;
  std::vector<Open> open_;
  std::vector<WarningStretch> closed_;
};

/// A cause's words for people ("tracking lost", ...); the name itself when unknown.
std::string warning_cause_words(const std::string& cause);

/// One line per cause for the end of a run: "poorly constrained tracking: frames 120-260 (141
/// frames), 300-310 (11 frames)"; at most `max_listed` stretches named per cause.
std::vector<std::string> warning_summary_lines(const std::vector<WarningStretch>& stretches,
                                               int max_listed = 5);

}  // namespace kfx::cli
