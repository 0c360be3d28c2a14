#pragma once
/// An output file written under a temporary name and renamed into place only on commit(), so a
/// failed run never leaves a file that looks finished.

#include <fstream>
#include <string>

namespace kfx::io {

/// Temporary files that must not outlive a killed run. The first registration installs handlers
/// for SIGINT, SIGTERM and SIGHUP that unlink every registered file (async-signal-safe: fixed
/// slots, unlink only) and then let the signal take its default effect. At most
/// kMaxLiveTempFiles files are tracked at once; more are still written, just not tracked.
namespace temp_files {

/// Files tracked at once (a run writes a handful of outputs at a time).
constexpr int kMaxLiveTempFiles = 32;

/// Tracks `path` until forget(); returns a slot for forget(), or −1 when none is free (or the
/// path is too long to track).
int track(const std::string& path);
/// Stops tracking the file in `slot` (it was renamed into place or removed); −1 is ignored.
void forget(int slot);

/// The temporary name kfx uses for `path`, owned by this process: `path.<pid>.tmp`.
std::string name_for(const std::string& path);

/// Removes temporaries of `path` left by kfx processes that no longer run (`path.<pid>.tmp`
/// whose pid is dead); returns how many were removed. Temporaries of live processes stay.
int remove_stale(const std::string& path);

}  // namespace temp_files

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
