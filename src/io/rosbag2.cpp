/// ROS 2 bags in rosbag2's sqlite3 storage: a folder with metadata.yaml and one .db3 file (or
/// the .db3 given directly); messages are CDR-serialised rows of the `messages` table.

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "core/platform.hpp"
#include "io/bag_container.hpp"

#if KFX_HAVE_SQLITE3
#include <sqlite3.h>
#endif

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

/// The .db3 file of a rosbag2 folder, or `path` itself when it is a file.
std::string find_database(const std::string& path) {
  std::error_code error;
  if (!fs::is_directory(path, error)) return path;
  std::vector<std::string> found;
  for (const auto& entry : fs::directory_iterator(path, error)) {
    if (entry.path().extension() == ".db3") found.push_back(entry.path().string());
  }
  if (found.empty()) {
    bool mcap = false;
    for (const auto& entry : fs::directory_iterator(path, error)) {
      mcap = mcap || entry.path().extension() == ".mcap";
    }
    KFX_CHECK(!mcap, "ROS 2 bag '" << path
                                   << "' is stored as mcap, which kfx does not read yet; convert "
                                      "it to sqlite3 (`ros2 bag convert` or rosbags-convert)");
    KFX_FAIL("ROS 2 bag '" << path << "' holds no .db3 file");
  }
  KFX_CHECK(found.size() == 1, "ROS 2 bag '" << path << "' is split into " << found.size()
                                             << " .db3 files, which kfx does not read yet");
  // Compressed bags name their mode in metadata.yaml; kfx reads plain messages only.
  std::ifstream metadata(fs::path(path) / "metadata.yaml");
  std::string line;
  while (std::getline(metadata, line)) {
    const auto at = line.find("compression_format:");
    if (at == std::string::npos) continue;
    std::string value = line.substr(at + 19);
    value.erase(std::remove_if(value.begin(), value.end(),
                               [](char c) { return c == ' ' || c == '"' || c == '\''; }),
                value.end());
    KFX_CHECK(value.empty(), "ROS 2 bag '" << path << "' is " << value
                                           << "-compressed, which kfx does not read yet");
  }
  return found.front();
}

#if KFX_HAVE_SQLITE3

/// ROS 2 spells types "sensor_msgs/msg/Image"; kfx compares them the ROS 1 way.
std::string ros1_type_name(std::string type) {
  const auto at = type.find("/msg/");
  if (at != std::string::npos) type.erase(at, 4);
  return type;
}

class Statement {
 public:
  Statement(sqlite3* db, const char* sql, const std::string& where) {
    KFX_CHECK(sqlite3_prepare_v2(db, sql, -1, &statement_, nullptr) == SQLITE_OK,
              where << ": cannot read it as a rosbag2 database (" << sqlite3_errmsg(db)
                    << "; truncated, corrupt, or not a rosbag2 bag?)");
  }
  ~Statement() { sqlite3_finalize(statement_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  sqlite3_stmt* get() { return statement_; }

 private:
  sqlite3_stmt* statement_ = nullptr;
};

class Ros2Bag : public BagContainer {
 public:
  explicit Ros2Bag(std::string path) : path_(std::move(path)) {
    const std::string database = find_database(path_);
    const std::string where = "ROS 2 bag '" + path_ + "'";
    // Read-only and immutable: never a journal or lock file beside someone's recording.
    std::string uri = "file:";
    for (const char c : database) {  // URI-escape what would end or bend the path
      if (c == '%' || c == '?' || c == '#') {
        char hex[4];
        std::snprintf(hex, sizeof(hex), "%%%02X", static_cast<unsigned char>(c));
        uri += hex;
      } else {
        uri += c;
      }
    }
    uri += "?immutable=1";
    const int rc =
        sqlite3_open_v2(uri.c_str(), &db_, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
    if (rc != SQLITE_OK) {
      const std::string problem = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      KFX_FAIL(where << ": cannot open '" << database << "': " << problem);
    }
    try {
      Statement topics(db_, "SELECT id, name, type, serialization_format FROM topics", where);
      int rc_step;
      while ((rc_step = sqlite3_step(topics.get())) == SQLITE_ROW) {
        const auto text = [&](int column) {
          const unsigned char* t = sqlite3_column_text(topics.get(), column);
          return t ? std::string(reinterpret_cast<const char*>(t)) : std::string();
        };
        KFX_CHECK(text(3) == "cdr", where << ": topic '" << text(1) << "' is serialised as '"
                                          << text(3) << "'; kfx reads cdr");
        topics_[sqlite3_column_int64(topics.get(), 0)] = BagTopic{text(1), ros1_type_name(text(2))};
      }
      KFX_CHECK(rc_step == SQLITE_DONE,
                where << ": cannot read its topics (" << sqlite3_errmsg(db_) << "; truncated?)");
      Statement messages(db_, "SELECT id, topic_id, timestamp FROM messages ORDER BY timestamp",
                         where);
      while ((rc_step = sqlite3_step(messages.get())) == SQLITE_ROW) {
        messages_[sqlite3_column_int64(messages.get(), 1)].push_back(
            BagMessage{sqlite3_column_int64(messages.get(), 2),
                       static_cast<uint64_t>(sqlite3_column_int64(messages.get(), 0)), 0});
      }
      KFX_CHECK(rc_step == SQLITE_DONE,
                where << ": cannot list its messages (" << sqlite3_errmsg(db_) << "; truncated?)");
    } catch (...) {
      sqlite3_close(db_);
      throw;
    }
  }
  ~Ros2Bag() override { sqlite3_close(db_); }
  Ros2Bag(const Ros2Bag&) = delete;
  Ros2Bag& operator=(const Ros2Bag&) = delete;

  const std::string& path() const override { return path_; }
  RosEncoding encoding() const override { return RosEncoding::kCdr; }

  std::vector<BagTopic> topics() const override {
    std::vector<BagTopic> out;
    for (const auto& [id, topic] : topics_) {
      if (messages_.count(id)) out.push_back(topic);
    }
    return out;
  }

  std::vector<BagMessage> messages(const std::string& topic) const override {
    for (const auto& [id, t] : topics_) {
      const auto it = messages_.find(id);
      if (t.name == topic && it != messages_.end()) return it->second;
    }
    return {};
  }

  std::vector<uint8_t> read(const BagMessage& message, const std::string& topic) override {
    std::ostringstream where;
    where << "ROS 2 bag '" << path_ << "', topic '" << topic << "', message at "
          << message.time_ns * 1e-9 << " s";
    Statement statement(db_, "SELECT data FROM messages WHERE id = ?", where.str());
    sqlite3_bind_int64(statement.get(), 1, static_cast<sqlite3_int64>(message.location));
    KFX_CHECK(sqlite3_step(statement.get()) == SQLITE_ROW,
              where.str() << ": cannot read it (" << sqlite3_errmsg(db_) << ")");
    const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(statement.get(), 0));
    const int bytes = sqlite3_column_bytes(statement.get(), 0);
    return std::vector<uint8_t>(data, data + bytes);
  }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
  std::map<int64_t, BagTopic> topics_;
  std::map<int64_t, std::vector<BagMessage>> messages_;
};

#endif

}  // namespace

std::unique_ptr<BagContainer> open_ros2_bag(const std::string& path) {
#if KFX_HAVE_SQLITE3
  return std::make_unique<Ros2Bag>(path);
#else
  find_database(path);
  KFX_FAIL("ROS 2 bag '" << path
                         << "': this kfx was built without sqlite3 (install libsqlite3-dev "
                            "and rebuild)");
#endif
}

}  // namespace kfx::io
