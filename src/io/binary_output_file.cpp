/// Binary output files written to a temporary name, then renamed.

#include "io/binary_output_file.hpp"

#include <cerrno>
#include <cstring>

#include "core/platform.hpp"
#include "io/atomic_file.hpp"

namespace kfx::io {

BinaryOutputFile::BinaryOutputFile(std::string path, const char* what)
    : path_(std::move(path)), temp_path_(temp_files::name_for(path_)), what_(what) {
  // Temporaries of earlier kfx runs that were killed before they could clean up (SIGKILL).
  temp_files::remove_stale(path_);
  file_ = std::fopen(temp_path_.c_str(), "wb");
  KFX_CHECK(file_ != nullptr, "cannot write " << what_ << " '" << path_ << "': cannot create '"
                                              << temp_path_ << "': " << std::strerror(errno));
  slot_ = temp_files::track(temp_path_);
}

BinaryOutputFile::~BinaryOutputFile() { abandon(); }

void BinaryOutputFile::abandon() {
  if (file_ == nullptr) return;
  std::fclose(file_);
  file_ = nullptr;
  std::remove(temp_path_.c_str());
  temp_files::forget(slot_);
  slot_ = -1;
}

void BinaryOutputFile::commit() {
  KFX_CHECK(file_ != nullptr, "cannot write " << what_ << " '" << path_ << "': already closed");
  std::FILE* file = file_;
  file_ = nullptr;
  // fclose flushes: its result decides whether the data reached the file.
  const bool failed = std::ferror(file) != 0;
  // Renamed or removed below either way: the signal handler no longer needs to know it.
  struct Forget {
    int& slot;
    ~Forget() {
      temp_files::forget(slot);
      slot = -1;
    }
  } forget{slot_};
  if (std::fclose(file) != 0 || failed) {
    const std::string reason = std::strerror(errno);
    std::remove(temp_path_.c_str());
    KFX_FAIL("cannot write " << what_ << " '" << path_ << "': " << reason);
  }
  if (std::rename(temp_path_.c_str(), path_.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(temp_path_.c_str());
    KFX_FAIL("cannot write " << what_ << " '" << path_ << "': cannot rename '" << temp_path_
                             << "' into place: " << reason);
  }
}

}  // namespace kfx::io
