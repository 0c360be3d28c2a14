#include "io/atomic_file.hpp"

#include <cstdio>

#include "core/platform.hpp"

namespace kfx::io {

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)), temp_path_(path_ + ".partial") {
  stream_.open(temp_path_, std::ios::out | std::ios::trunc);
  KFX_CHECK(stream_.is_open(), "cannot write '" << temp_path_ << "'");
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    stream_.close();
    std::remove(temp_path_.c_str());
  }
}

void AtomicFile::commit() {
  stream_.flush();
  KFX_CHECK(stream_.good(), "error while writing '" << temp_path_ << "'");
  stream_.close();
  KFX_CHECK(std::rename(temp_path_.c_str(), path_.c_str()) == 0,
            "cannot rename '" << temp_path_ << "' to '" << path_ << "'");
  committed_ = true;
}

}  // namespace kfx::io
