#pragma once
/// A binary output file (PNG, SLAMBench .raw) written under `path.<pid>.tmp` and renamed into
/// place only on commit(), so a failed run never leaves a file that looks finished. The
/// temporary is removed on SIGINT/SIGTERM/SIGHUP, and stale ones of dead kfx processes are
/// removed when the same path is written again. (Text outputs use AtomicFile from
/// io/atomic_file.hpp; they are small and the log's partial file is meant to survive a kill.)

#include <cstdio>
#include <string>

namespace kfx::io {

/// A C stdio stream (for libpng and bulk fwrite) to a temporary file that becomes `path` on
/// commit(); destroyed uncommitted, it removes the temporary file.
class BinaryOutputFile {
 public:
  /// Creates `path.<pid>.tmp`, first removing stale temporaries of `path` left by dead
  /// processes. Throws kfx::Error naming `path` (what: e.g. "PNG") on failure.
  BinaryOutputFile(std::string path, const char* what);
  ~BinaryOutputFile();
  BinaryOutputFile(const BinaryOutputFile&) = delete;
  BinaryOutputFile& operator=(const BinaryOutputFile&) = delete;

  /// The open stream (null after commit() or abandon()).
  std::FILE* file() const { return file_; }
  /// Closes (flushing) and renames to the final path. Throws kfx::Error naming the file and the
  /// system's reason on failure, after removing the temporary file.
  void commit();
  /// Closes and removes the temporary file; safe to call more than once.
  void abandon();
  /// The final path.
  const std::string& path() const { return path_; }
  /// The temporary path written until commit().
  const std::string& temp_path() const { return temp_path_; }

 private:
  std::string path_;
  std::string temp_path_;
  std::string what_;
  std::FILE* file_ = nullptr;
  int slot_ = -1;  ///< temp_files slot: removed if the process is interrupted
};

}  // namespace kfx::io
