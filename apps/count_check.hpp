#pragma once
/// A CLI11 check for whole-number counts (frames, passes) whose message states the allowed range
/// plainly ("a whole number >= 1"), unlike CLI11's own numeric ranges, which print their limits
/// as doubles ("0.000000 to 1.79e308").

#include <CLI/CLI.hpp>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <string>

namespace kfx::cli {

/// Accepts whole numbers from `minimum` to INT_MAX; `meaning` explains the value ("0 = all
/// frames") in the message.
inline CLI::Validator count_at_least(int minimum, const std::string& meaning) {
  const std::string range = "a whole number >= " + std::to_string(minimum) +
                            (meaning.empty() ? "" : " (" + meaning + ")");
  return CLI::Validator(
      [minimum, range](std::string& text) -> std::string {
        char* end = nullptr;
        errno = 0;
        const long value = std::strtol(text.c_str(), &end, 10);
        const bool whole = !text.empty() && end != nullptr && *end == '\0' && errno == 0;
        if (whole && value >= minimum && value <= INT_MAX) return "";
        return "must be " + range + ", got '" + text + "'";
      },
      range);
}

}  // namespace kfx::cli
