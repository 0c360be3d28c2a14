#include "warning_stretches.hpp"

#include <algorithm>
#include <map>

namespace kfx::cli {

WarningStretches::Open& WarningStretches::slot(const std::string& cause) {
  for (auto& o : open_) {
    if (o.cause == cause) return o;
  }
  open_.push_back(Open{cause, {}, 0, false});
  return open_.back();
}

void WarningStretches::observe(const std::string& cause, int frame, bool present) {
  Open& o = slot(cause);
  if (present) {
    if (!o.open) {
      o.stretch = WarningStretch{cause, frame, frame, 0};
      o.open = true;
    }
    o.stretch.last_frame = frame;
    ++o.stretch.frames;
    o.frames_without = 0;
  } else if (o.open && ++o.frames_without >= frames_to_end_) {
    closed_.push_back(o.stretch);
    o.open = false;
  }
}

std::vector<WarningStretch> WarningStretches::stretches() const {
  std::vector<WarningStretch> all = closed_;
  for (const auto& o : open_) {
    if (o.open) all.push_back(o.stretch);
  }
  std::stable_sort(all.begin(), all.end(), [](const WarningStretch& a, const WarningStretch& b) {
    return a.first_frame != b.first_frame ? a.first_frame < b.first_frame : a.cause < b.cause;
  });
  return all;
}

nlohmann::json WarningStretches::to_json() const {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& s : stretches()) {
    out.push_back({{"cause", s.cause},
                   {"description", warning_cause_words(s.cause)},
                   {"first_frame", s.first_frame},
                   {"last_frame", s.last_frame},
                   {"frames", s.frames}});
  }
  return out;
}

std::string warning_cause_words(const std::string& cause) {
  static const std::map<std::string, std::string> words = {
      {"lost_tracking", "tracking lost (pose kept, frame not integrated)"},
      {"poorly_constrained_tracking", "tracking poorly constrained (the pose may slide unnoticed)"},
      {"camera_outside_volume", "camera outside the volume"},
      {"depth_outside_volume", "most depth outside the volume or beyond the far plane"},
      {"implausible_depth", "depth implausible for the depth scale"},
      {"diverged", "diverged: aligned position error above the divergence bound"},
      {"map_full", "block map full: blocks of the surface not stored"},
      {"skipped_bad_frame", "bad frame skipped"}};
  const auto it = words.find(cause);
  return it == words.end() ? cause : it->second;
}

std::vector<std::string> warning_summary_lines(const std::vector<WarningStretch>& stretches,
                                               int max_listed) {
  std::vector<std::string> causes;  // in order of first appearance
  for (const auto& s : stretches) {
    if (std::find(causes.begin(), causes.end(), s.cause) == causes.end()) causes.push_back(s.cause);
  }
  std::vector<std::string> lines;
  for (const auto& cause : causes) {
    std::string line = warning_cause_words(cause) + ": ";
    int listed = 0, total_stretches = 0, total_frames = 0;
    for (const auto& s : stretches) {
      if (s.cause != cause) continue;
      ++total_stretches;
      total_frames += s.frames;
      if (listed >= max_listed) continue;
      line += (listed++ ? ", " : "") + (s.first_frame == s.last_frame
                                            ? "frame " + std::to_string(s.first_frame)
                                            : "frames " + std::to_string(s.first_frame) + "-" +
                                                  std::to_string(s.last_frame));
      line += " (" + std::to_string(s.frames) + ")";
    }
    if (total_stretches > listed) {
      line += " and " + std::to_string(total_stretches - listed) + " more stretch(es)";
    }
    line += "; " + std::to_string(total_frames) + " frame(s) in all";
    lines.push_back(line);
  }
  return lines;
}

}  // namespace kfx::cli
