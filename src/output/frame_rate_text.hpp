#pragma once
/// Figures as the terminal and report.html print them, from one place so the two agree: frames/s
/// to one decimal (the report reads the same text out of its data), percentages, durations.

#include <string>

namespace kfx::output {

/// Frames/s to one decimal ("3.3"); "0.0" for no figure.
std::string frame_rate_text(double frames_per_second);

/// A percentage to the whole number below, so 100 only when done ("42").
std::string percent_text(double percent);

/// A duration for people: "45 s", "12 min 5 s", "2 h 3 min" (rounded to the second).
std::string duration_text(double seconds);

}  // namespace kfx::output
