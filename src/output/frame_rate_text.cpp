#include "output/frame_rate_text.hpp"

#include <cmath>
#include <cstdio>

namespace kfx::output {

std::string frame_rate_text(double frames_per_second) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.1f",
                std::isfinite(frames_per_second) ? frames_per_second : 0.0);
  return buffer;
}

std::string percent_text(double percent) {
  if (!std::isfinite(percent)) percent = 0;
  return std::to_string(static_cast<long long>(std::floor(percent)));
}

std::string duration_text(double seconds) {
  const long long s = std::isfinite(seconds) && seconds > 0 ? std::llround(seconds) : 0;
  if (s < 60) return std::to_string(s) + " s";
  if (s < 3600) return std::to_string(s / 60) + " min " + std::to_string(s % 60) + " s";
  return std::to_string(s / 3600) + " h " + std::to_string(s % 3600 / 60) + " min";
}

}  // namespace kfx::output
