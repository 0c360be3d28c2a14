#pragma once
/// An output file written under a temporary name and renamed into place only on commit(), so a
/// failed run never leaves a file that looks finished.

#include <fstream>
#include <string>

namespace kfx::io {

/// A text output stream to `path` that becomes visible only when committed.
class AtomicFile {
 public:
  /// Opens `path + ".partial"` for writing; throws kfx::Error naming the path on failure.
  explicit AtomicFile(std::string path);
  /// Removes the temporary file unless commit() ran.
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// The stream to write to.
  std::ofstream& stream() { return stream_; }
  /// Flushes, closes and renames to the final path; throws on an I/O error.
  void commit();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::string temp_path_;
  std::ofstream stream_;
  bool committed_ = false;
};

}  // namespace kfx::io
