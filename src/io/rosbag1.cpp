/// ROS 1 bags, format 2.0 (what `rosbag record`, `rosbags` and librealsense's recorder write):
/// the index at the end lists connections and chunks; each chunk is followed by per-connection
/// index records giving every message's time and offset, so frames are found without
/// decompressing the whole file.

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>

#include "core/platform.hpp"
#include "io/bag_container.hpp"

#if KFX_HAVE_BZIP2
#include <bzlib.h>
#endif
#if KFX_HAVE_LZ4
#include <lz4frame.h>
#endif

namespace kfx::io {
namespace {

namespace fs = std::filesystem;

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr size_t kMagicBytes = sizeof(kMagic) - 1;
/// Largest record header and uncompressed chunk accepted; more means a corrupt file.
constexpr uint32_t kMaxHeaderBytes = 1u << 20;
constexpr uint32_t kMaxChunkBytes = 1u << 30;

enum Op : uint8_t {
  kMessageData = 0x02,
  kBagHeader = 0x03,
  kIndexData = 0x04,
  kChunk = 0x05,
  kChunkInfo = 0x06,
  kConnection = 0x07,
};

/// A record's header fields (name → raw value bytes) and where its data lies.
struct Record {
  std::map<std::string, std::string> fields;
  uint64_t data_pos = 0;
  uint32_t data_bytes = 0;
  uint64_t end = 0;  ///< the byte after the record

  bool has(const char* name) const { return fields.count(name) != 0; }
};

template <typename T>
T field_value(const Record& record, const char* name, const std::string& where) {
  const auto it = record.fields.find(name);
  KFX_CHECK(it != record.fields.end(), where << ": record lacks its '" << name << "' field");
  KFX_CHECK(it->second.size() == sizeof(T), where << ": field '" << name << "' has "
                                                  << it->second.size() << " bytes, expected "
                                                  << sizeof(T));
  T value;
  std::memcpy(&value, it->second.data(), sizeof(T));
  return value;
}

/// Parses header fields (uint32 length, then "name=value") from `bytes`.
std::map<std::string, std::string> parse_fields(const uint8_t* bytes, size_t size,
                                                const std::string& where) {
  std::map<std::string, std::string> fields;
  size_t pos = 0;
  while (pos < size) {
    KFX_CHECK(size - pos >= 4, where << ": a header field's length is cut off");
    uint32_t length;
    std::memcpy(&length, bytes + pos, 4);
    pos += 4;
    KFX_CHECK(length <= size - pos, where << ": a header field runs past its header");
    const char* text = reinterpret_cast<const char*>(bytes + pos);
    const char* equals = static_cast<const char*>(std::memchr(text, '=', length));
    KFX_CHECK(equals != nullptr, where << ": a header field has no '='");
    fields[std::string(text, equals)] = std::string(equals + 1, text + length);
    pos += length;
  }
  return fields;
}

/// Parses the record at `pos` of `bytes` (a decompressed chunk).
Record parse_record(const std::vector<uint8_t>& bytes, uint64_t pos, const std::string& where) {
  KFX_CHECK(pos <= bytes.size() && bytes.size() - pos >= 4, where << ": record cut off");
  uint32_t header_bytes;
  std::memcpy(&header_bytes, bytes.data() + pos, 4);
  KFX_CHECK(header_bytes <= bytes.size() - pos - 4 && bytes.size() - pos - 4 - header_bytes >= 4,
            where << ": record header runs past the chunk");
  Record record;
  record.fields = parse_fields(bytes.data() + pos + 4, header_bytes, where);
  record.data_pos = pos + 8 + header_bytes;
  std::memcpy(&record.data_bytes, bytes.data() + pos + 4 + header_bytes, 4);
  KFX_CHECK(record.data_bytes <= bytes.size() - record.data_pos,
            where << ": record data runs past the chunk");
  record.end = record.data_pos + record.data_bytes;
  return record;
}

class Ros1Bag : public BagContainer {
 public:
  explicit Ros1Bag(std::string path) : path_(std::move(path)) {
    std::error_code error;
    size_ = fs::file_size(path_, error);
    KFX_CHECK(!error, "cannot read ROS bag '" << path_ << "': " << error.message());
    file_ = std::fopen(path_.c_str(), "rb");
    KFX_CHECK(file_ != nullptr, "cannot open ROS bag '" << path_ << "': " << std::strerror(errno));
    try {
      open_index();
    } catch (...) {
      std::fclose(file_);
      throw;
    }
  }
  ~Ros1Bag() override { std::fclose(file_); }
  Ros1Bag(const Ros1Bag&) = delete;
  Ros1Bag& operator=(const Ros1Bag&) = delete;

  const std::string& path() const override { return path_; }
  RosEncoding encoding() const override { return RosEncoding::kRos1; }

  std::vector<BagTopic> topics() const override {
    std::map<std::string, BagTopic> by_name;
    for (const auto& [id, connection] : connections_) {
      const auto it = messages_.find(id);
      if (it != messages_.end() && !it->second.empty()) by_name[connection.name] = connection;
    }
    std::vector<BagTopic> out;
    for (auto& entry : by_name) out.push_back(entry.second);
    return out;
  }

  std::vector<BagMessage> messages(const std::string& topic) const override {
    std::vector<BagMessage> out;
    for (const auto& [id, connection] : connections_) {
      if (connection.name != topic) continue;
      const auto it = messages_.find(id);
      if (it != messages_.end()) out.insert(out.end(), it->second.begin(), it->second.end());
    }
    std::stable_sort(out.begin(), out.end(), [](const BagMessage& a, const BagMessage& b) {
      return a.time_ns < b.time_ns;
    });
    return out;
  }

  std::vector<uint8_t> read(const BagMessage& message, const std::string& topic) override {
    std::ostringstream where;
    where << "ROS bag '" << path_ << "', topic '" << topic << "', message at "
          << message.time_ns * 1e-9 << " s";
    KFX_CHECK(message.location < chunk_positions_.size(), where.str() << ": no such chunk");
    const std::vector<uint8_t>& chunk = cached_chunk(message.location, where.str());
    const Record record = parse_record(chunk, message.offset, where.str());
    KFX_CHECK(record.has("op") && field_value<uint8_t>(record, "op", where.str()) == kMessageData,
              where.str() << ": the index points at a record that is not a message");
    return std::vector<uint8_t>(chunk.begin() + static_cast<std::ptrdiff_t>(record.data_pos),
                                chunk.begin() + static_cast<std::ptrdiff_t>(record.end));
  }

 private:
  void read_bytes(uint64_t pos, void* out, size_t n, const std::string& where) {
    KFX_CHECK(pos <= size_ && n <= size_ - pos, where << ": truncated (needs " << n
                                                      << " bytes at byte " << pos
                                                      << " but the file ends at " << size_ << ")");
    KFX_CHECK(
        fseeko(file_, static_cast<off_t>(pos), SEEK_SET) == 0 && std::fread(out, 1, n, file_) == n,
        where << ": read failed at byte " << pos);
  }

  /// The record at file position `pos` (its data left unread).
  Record read_record(uint64_t pos, const std::string& where) {
    uint32_t header_bytes = 0;
    read_bytes(pos, &header_bytes, 4, where);
    KFX_CHECK(header_bytes <= kMaxHeaderBytes, where << ": corrupt record at byte " << pos
                                                     << " (header of " << header_bytes
                                                     << " bytes)");
    std::vector<uint8_t> header(header_bytes);
    read_bytes(pos + 4, header.data(), header_bytes, where);
    Record record;
    record.fields = parse_fields(header.data(), header.size(), where);
    read_bytes(pos + 4 + header_bytes, &record.data_bytes, 4, where);
    record.data_pos = pos + 8 + header_bytes;
    KFX_CHECK(record.data_bytes <= size_ - std::min(size_, record.data_pos),
              where << ": truncated: the record at byte " << pos << " needs " << record.data_bytes
                    << " data bytes but the file ends at " << size_);
    record.end = record.data_pos + record.data_bytes;
    return record;
  }

  void open_index() {
    const std::string where = "ROS bag '" + path_ + "'";
    char magic[kMagicBytes] = {};
    KFX_CHECK(size_ >= kMagicBytes, where << " is not a ROS bag: it is only " << size_ << " bytes");
    read_bytes(0, magic, kMagicBytes, where);
    KFX_CHECK(std::memcmp(magic, "#ROSBAG V", 9) == 0,
              where << " is not a ROS bag (it does not start with '#ROSBAG V')");
    KFX_CHECK(std::memcmp(magic, kMagic, kMagicBytes) == 0,
              where << " is a ROS bag of a version kfx does not read (kfx reads format 2.0)");
    const Record header = read_record(kMagicBytes, where);
    KFX_CHECK(field_value<uint8_t>(header, "op", where) == kBagHeader,
              where << ": the first record is not the bag header");
    const uint64_t index_pos = field_value<uint64_t>(header, "index_pos", where);
    const int32_t connection_count = field_value<int32_t>(header, "conn_count", where);
    const int32_t chunk_count = field_value<int32_t>(header, "chunk_count", where);
    KFX_CHECK(index_pos != 0 && connection_count > 0,
              where << " is unindexed (the recording was not closed cleanly); `rosbag reindex` "
                       "repairs it");
    KFX_CHECK(index_pos >= header.end && index_pos < size_,
              where << " is truncated: its index should start at byte " << index_pos
                    << " but the file ends at " << size_);
    // The index: connection records, then chunk-info records.
    std::vector<uint64_t> chunk_positions;
    for (uint64_t pos = index_pos; pos < size_;) {
      const Record record = read_record(pos, where);
      const uint8_t op = field_value<uint8_t>(record, "op", where);
      if (op == kConnection) {
        const int32_t id = field_value<int32_t>(record, "conn", where);
        std::vector<uint8_t> data(record.data_bytes);
        read_bytes(record.data_pos, data.data(), data.size(), where);
        const auto fields = parse_fields(data.data(), data.size(), where);
        const auto type = fields.find("type");
        KFX_CHECK(record.has("topic") && type != fields.end(),
                  where << ": connection " << id << " lacks its topic or type");
        connections_[id] = BagTopic{record.fields.at("topic"), type->second};
      } else if (op == kChunkInfo) {
        chunk_positions.push_back(field_value<uint64_t>(record, "chunk_pos", where));
      }
      pos = record.end;
    }
    KFX_CHECK(static_cast<int32_t>(connections_.size()) == connection_count &&
                  static_cast<int32_t>(chunk_positions.size()) == chunk_count,
              where << " is truncated or corrupt: its header lists " << connection_count
                    << " connections and " << chunk_count << " chunks, its index "
                    << connections_.size() << " and " << chunk_positions.size());
    // Each chunk is followed by its index records: every message's time and offset.
    for (size_t i = 0; i < chunk_positions.size(); ++i) {
      const uint64_t chunk_pos = chunk_positions[i];
      KFX_CHECK(chunk_pos < index_pos,
                where << ": chunk " << i << " lies at byte " << chunk_pos << ", past the index");
      const Record chunk = read_record(chunk_pos, where);
      KFX_CHECK(field_value<uint8_t>(chunk, "op", where) == kChunk,
                where << ": chunk " << i << " at byte " << chunk_pos << " is not a chunk record");
      chunk_positions_.push_back(chunk_pos);
      for (uint64_t pos = chunk.end; pos < index_pos;) {
        const Record record = read_record(pos, where);
        if (field_value<uint8_t>(record, "op", where) != kIndexData) break;
        const int32_t id = field_value<int32_t>(record, "conn", where);
        const uint32_t count = field_value<uint32_t>(record, "count", where);
        KFX_CHECK(static_cast<uint64_t>(count) * 12 == record.data_bytes,
                  where << ": index of chunk " << i << " lists " << count << " messages in "
                        << record.data_bytes << " bytes");
        std::vector<uint8_t> entries(record.data_bytes);
        read_bytes(record.data_pos, entries.data(), entries.size(), where);
        auto& list = messages_[id];
        for (uint32_t k = 0; k < count; ++k) {
          uint32_t sec, nsec, offset;
          std::memcpy(&sec, entries.data() + 12 * k, 4);
          std::memcpy(&nsec, entries.data() + 12 * k + 4, 4);
          std::memcpy(&offset, entries.data() + 12 * k + 8, 4);
          list.push_back(BagMessage{static_cast<int64_t>(sec) * 1000000000 + nsec, i, offset});
        }
        pos = record.end;
      }
    }
  }

  const std::vector<uint8_t>& cached_chunk(uint64_t index, const std::string& where) {
    constexpr size_t kCachedChunks = 4;
    auto it = std::find_if(chunks_.begin(), chunks_.end(),
                           [&](const auto& entry) { return entry.first == index; });
    if (it == chunks_.end()) {
      std::vector<uint8_t> chunk = read_chunk(chunk_positions_[index], where);
      if (chunks_.size() == kCachedChunks) chunks_.pop_back();
      chunks_.insert(chunks_.begin(), {index, std::move(chunk)});
    } else if (it != chunks_.begin()) {
      std::rotate(chunks_.begin(), it, it + 1);
    }
    return chunks_.front().second;
  }

  std::vector<uint8_t> read_chunk(uint64_t pos, const std::string& where) {
    const Record chunk = read_record(pos, where);
    const auto compression = chunk.fields.find("compression");
    KFX_CHECK(compression != chunk.fields.end(), where << ": the chunk has no compression field");
    const uint32_t size = field_value<uint32_t>(chunk, "size", where);
    KFX_CHECK(size <= kMaxChunkBytes, where << ": absurd chunk size " << size);
    std::vector<uint8_t> stored(chunk.data_bytes);
    read_bytes(chunk.data_pos, stored.data(), stored.size(), where);
    if (compression->second == "none") {
      KFX_CHECK(stored.size() == size,
                where << ": chunk holds " << stored.size() << " bytes, its header says " << size);
      return stored;
    }
    std::vector<uint8_t> out(size);
    if (compression->second == "bz2") {
#if KFX_HAVE_BZIP2
      unsigned int out_bytes = size;
      const int rc = BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(out.data()), &out_bytes,
                                                reinterpret_cast<char*>(stored.data()),
                                                static_cast<unsigned int>(stored.size()), 0, 0);
      KFX_CHECK(rc == BZ_OK && out_bytes == size,
                where << ": corrupt bz2 chunk at byte " << pos << " (bzip2 error " << rc << ")");
      return out;
#else
      KFX_FAIL(where << ": its chunks are bz2-compressed and this kfx was built without libbz2 "
                        "(install libbz2-dev and rebuild)");
#endif
    }
    if (compression->second == "lz4") {
#if KFX_HAVE_LZ4
      LZ4F_dctx* context = nullptr;
      KFX_CHECK(!LZ4F_isError(LZ4F_createDecompressionContext(&context, LZ4F_VERSION)),
                where << ": cannot start lz4 decompression");
      size_t in_pos = 0, out_pos = 0, rc = 1;
      while (rc != 0 && in_pos < stored.size() && out_pos < out.size()) {
        size_t in_bytes = stored.size() - in_pos, out_bytes = out.size() - out_pos;
        rc = LZ4F_decompress(context, out.data() + out_pos, &out_bytes, stored.data() + in_pos,
                             &in_bytes, nullptr);
        if (LZ4F_isError(rc)) break;
        in_pos += in_bytes;
        out_pos += out_bytes;
        if (in_bytes == 0 && out_bytes == 0) break;
      }
      LZ4F_freeDecompressionContext(context);
      KFX_CHECK(!LZ4F_isError(rc) && out_pos == size,
                where << ": corrupt lz4 chunk at byte " << pos);
      return out;
#else
      KFX_FAIL(where << ": its chunks are lz4-compressed and this kfx was built without liblz4 "
                        "(install liblz4-dev and rebuild)");
#endif
    }
    KFX_FAIL(where << ": unknown chunk compression '" << compression->second << "'");
  }

  std::string path_;
  uint64_t size_ = 0;
  std::FILE* file_ = nullptr;
  std::map<int32_t, BagTopic> connections_;
  std::map<int32_t, std::vector<BagMessage>> messages_;
  std::vector<uint64_t> chunk_positions_;
  /// The last chunks read, newest first: pairing colour with depth reads back and forth across
  /// neighbouring chunks.
  std::vector<std::pair<uint64_t, std::vector<uint8_t>>> chunks_;
};

}  // namespace

std::unique_ptr<BagContainer> open_ros1_bag(const std::string& path) {
  return std::make_unique<Ros1Bag>(path);
}

}  // namespace kfx::io
