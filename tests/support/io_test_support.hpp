#pragma once
/// Test helpers shared by the I/O tests (PNG, .raw, readers, trajectories): a temporary folder,
/// whole-file reads and writes, and expectations on kfx::Error messages and reader results.

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "core/platform.hpp"
#include "io/reader.hpp"

namespace kfx::io::test {

/// A fresh temporary folder named `prefix` plus a random suffix, removed with everything in it
/// at the end of the test.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix) {
    std::string pattern = (std::filesystem::temp_directory_path() / (prefix + "_XXXXXX")).string();
    EXPECT_NE(mkdtemp(pattern.data()), nullptr);
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code error;
    std::filesystem::remove_all(path_, error);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  /// Path of `name` inside the temporary folder (not created).
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  /// A sub-folder (created) of the temporary folder.
  std::string folder(const std::string& name) const {
    std::filesystem::create_directories(path_ / name);
    return (path_ / name).string();
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// Writes `text` to `path`, replacing any existing file.
inline void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

/// The whole content of the text file `path` (empty when it cannot be read).
inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

/// The whole content of the file `path` as bytes (empty when it cannot be read).
inline std::vector<char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Writes `bytes` to `path`, replacing any existing file.
inline void write_bytes(const std::string& path, const std::vector<char>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// Expects `call` to throw kfx::Error whose message contains every string in `parts`.
template <class F>
void expect_error(F call, const std::vector<std::string>& parts) {
  try {
    call();
    ADD_FAILURE() << "no kfx::Error thrown";
  } catch (const Error& e) {
    for (const std::string& part : parts) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos)
          << "message '" << e.what() << "' lacks '" << part << "'";
    }
  }
}

/// Expects the next frame to be bad with a message containing every string in `parts`.
inline void expect_bad_frame(Reader& reader, const std::vector<std::string>& parts) {
  Frame frame;
  const ReadResult result = reader.next(frame);
  ASSERT_EQ(result.status, ReadStatus::kBadFrame) << result.message;
  for (const std::string& part : parts) {
    EXPECT_NE(result.message.find(part), std::string::npos)
        << "message '" << result.message << "' lacks '" << part << "'";
  }
}

/// Expects the next frame to read without error, and returns it.
inline Frame expect_ok_frame(Reader& reader) {
  Frame frame;
  const ReadResult result = reader.next(frame);
  EXPECT_EQ(result.status, ReadStatus::kOk) << result.message;
  return frame;
}

/// Expects the reader to be at the end of its input.
inline void expect_end(Reader& reader) {
  Frame frame;
  EXPECT_EQ(reader.next(frame).status, ReadStatus::kEnd);
}

}  // namespace kfx::io::test
