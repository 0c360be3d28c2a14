#pragma once
/// The one exception type of kfx: every error of the library (bad settings, unreadable input,
/// a frame of the wrong size, no GPU) is thrown as kfx::Error with a message that names the
/// problem (and the file and frame where there is one).

#include <stdexcept>
#include <string>

namespace kfx {

/// A clear message plus the source location that raised it. Print `what()`; `where()` is for
/// debugging.
class Error : public std::runtime_error {
 public:
  Error(const std::string& message, const char* file, int line)
      : std::runtime_error(message), where_(std::string(file) + ":" + std::to_string(line)) {}
  /// Source location (file:line) that raised the error.
  const std::string& where() const { return where_; }

 private:
  std::string where_;
};

}  // namespace kfx
