#pragma once
/// Shared by the fuzz targets: the readers take paths, so each input is written to a file in a
/// per-process scratch folder first. Bad input must end in kfx::Error (caught by the targets);
/// only crashes, sanitizer reports, leaks, hangs and out-of-memory count as findings.

#include <stdlib.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace kfx::fuzz {

/// This process's scratch folder (created once, under TMPDIR or /tmp).
inline const std::filesystem::path& scratch() {
  static const std::filesystem::path folder = [] {
    std::string pattern = (std::filesystem::temp_directory_path() / "kfx_fuzz_XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) abort();
    return std::filesystem::path(pattern);
  }();
  return folder;
}

/// Writes `size` bytes to `name` in the scratch folder (replacing it); returns its path.
inline std::string write_file(const std::string& name, const uint8_t* data, size_t size) {
  const std::filesystem::path path = scratch() / name;
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path.string();
}

/// The input as text.
inline std::string as_text(const uint8_t* data, size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

}  // namespace kfx::fuzz
