#pragma once
/// Test helpers for recordings: ROS 1 messages (Image, CameraInfo, Float32, Transform) and a
/// small ROS 1 bag writer (format 2.0, one uncompressed chunk and its index), so that tests
/// build exactly the good and bad bags they need.

#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

namespace kfx::io::test {

/// Little-endian bytes of a ROS 1 message or a bag record, appended field by field.
class Bytes {
 public:
  template <typename T>
  Bytes& put(T value) {
    const auto* p = reinterpret_cast<const uint8_t*>(&value);
    data_.insert(data_.end(), p, p + sizeof(T));
    return *this;
  }
  Bytes& raw(const std::vector<uint8_t>& bytes) {
    data_.insert(data_.end(), bytes.begin(), bytes.end());
    return *this;
  }
  Bytes& string(const std::string& text) {
    put<uint32_t>(static_cast<uint32_t>(text.size()));
    data_.insert(data_.end(), text.begin(), text.end());
    return *this;
  }
  const std::vector<uint8_t>& data() const { return data_; }
  size_t size() const { return data_.size(); }

 private:
  std::vector<uint8_t> data_;
};

/// A ROS 1 std_msgs/Header.
inline void ros1_header(Bytes& b, double stamp_s, const std::string& frame_id = "camera") {
  const auto sec = static_cast<uint32_t>(stamp_s);
  b.put<uint32_t>(0).put<uint32_t>(sec);
  b.put<uint32_t>(static_cast<uint32_t>((stamp_s - sec) * 1e9 + 0.5));
  b.string(frame_id);
}

/// A ROS 1 sensor_msgs/Image of `pixels` (rows packed, `bytes_per_px` each).
inline std::vector<uint8_t> ros1_image(double stamp_s, uint32_t width, uint32_t height,
                                       const std::string& encoding, uint32_t bytes_per_px,
                                       const std::vector<uint8_t>& pixels) {
  Bytes b;
  ros1_header(b, stamp_s);
  b.put<uint32_t>(height).put<uint32_t>(width).string(encoding).put<uint8_t>(0);
  b.put<uint32_t>(width * bytes_per_px).put<uint32_t>(static_cast<uint32_t>(pixels.size()));
  return b.raw(pixels).data();
}

/// 16UC1 depth of w×h from millimetre values (row-major).
inline std::vector<uint8_t> ros1_depth(double stamp_s, uint32_t w, uint32_t h,
                                       const std::vector<uint16_t>& mm,
                                       const std::string& encoding = "16UC1") {
  std::vector<uint8_t> pixels(mm.size() * 2);
  std::memcpy(pixels.data(), mm.data(), pixels.size());
  return ros1_image(stamp_s, w, h, encoding, 2, pixels);
}

/// A ROS 1 sensor_msgs/CameraInfo with K from fx, fy, cx, cy.
inline std::vector<uint8_t> ros1_camera_info(uint32_t w, uint32_t h, double fx, double fy,
                                             double cx, double cy) {
  Bytes b;
  ros1_header(b, 0.0);
  b.put<uint32_t>(h).put<uint32_t>(w).string("plumb_bob");
  b.put<uint32_t>(5);
  for (int i = 0; i < 5; ++i) b.put<double>(0.0);
  for (double k : {fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0}) b.put<double>(k);
  for (double r : {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}) b.put<double>(r);
  for (double p : {fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0}) b.put<double>(p);
  b.put<uint32_t>(0).put<uint32_t>(0);
  b.put<uint32_t>(0).put<uint32_t>(0).put<uint32_t>(0).put<uint32_t>(0).put<uint8_t>(0);
  return b.data();
}

/// A ROS 1 bag: connections (topic, type) and their messages, written as format 2.0.
class Ros1BagBuilder {
 public:
  /// Adds a connection; returns its id.
  int connection(const std::string& topic, const std::string& type) {
    connections_.push_back({topic, type});
    return static_cast<int>(connections_.size()) - 1;
  }
  /// Adds a message on connection `id`, recorded at `time_s`.
  void message(int id, double time_s, std::vector<uint8_t> data) {
    messages_.push_back({id, time_s, std::move(data)});
  }

  /// The bag's bytes; `indexed` false leaves the header's index position 0 and no index, as a
  /// recorder that died leaves it.
  std::vector<char> bytes(bool indexed = true) const {
    Bytes chunk;
    for (size_t c = 0; c < connections_.size(); ++c) connection_record(chunk, static_cast<int>(c));
    std::vector<std::vector<std::pair<double, uint32_t>>> index(connections_.size());
    for (const auto& m : messages_) {
      index[m.connection].push_back({m.time_s, static_cast<uint32_t>(chunk.size())});
      Bytes header;
      field(header, "op", uint8_t{0x02});
      field(header, "conn", static_cast<int32_t>(m.connection));
      field(header, "time", time_value(m.time_s));
      record(chunk, header, m.data);
    }
    Bytes file;
    const std::string magic = "#ROSBAG V2.0\n";
    file.raw(std::vector<uint8_t>(magic.begin(), magic.end()));
    const size_t header_at = file.size();
    bag_header(file, 0);
    const uint64_t chunk_pos = file.size();
    Bytes chunk_header;
    field(chunk_header, "op", uint8_t{0x05});
    field(chunk_header, "compression", std::string("none"));
    field(chunk_header, "size", static_cast<uint32_t>(chunk.size()));
    record(file, chunk_header, chunk.data());
    for (size_t c = 0; c < connections_.size(); ++c) {
      Bytes header, data;
      field(header, "op", uint8_t{0x04});
      field(header, "ver", int32_t{1});
      field(header, "conn", static_cast<int32_t>(c));
      field(header, "count", static_cast<uint32_t>(index[c].size()));
      for (const auto& [time_s, offset] : index[c]) {
        data.put<uint64_t>(time_value(time_s)).put<uint32_t>(offset);
      }
      record(file, header, data.data());
    }
    std::vector<uint8_t> out = file.data();
    if (!indexed) return std::vector<char>(out.begin(), out.end());
    const uint64_t index_pos = out.size();
    Bytes index_section;
    for (size_t c = 0; c < connections_.size(); ++c) {
      connection_record(index_section, static_cast<int>(c));
    }
    Bytes info_header, info;
    field(info_header, "op", uint8_t{0x06});
    field(info_header, "ver", int32_t{1});
    field(info_header, "chunk_pos", chunk_pos);
    field(info_header, "start_time", uint64_t{0});
    field(info_header, "end_time", uint64_t{0});
    field(info_header, "count", static_cast<int32_t>(connections_.size()));
    for (size_t c = 0; c < connections_.size(); ++c) {
      info.put<int32_t>(static_cast<int32_t>(c))
          .put<uint32_t>(static_cast<uint32_t>(index[c].size()));
    }
    record(index_section, info_header, info.data());
    out.insert(out.end(), index_section.data().begin(), index_section.data().end());
    Bytes header;
    bag_header(header, index_pos);
    std::copy(header.data().begin(), header.data().end(), out.begin() + header_at);
    return std::vector<char>(out.begin(), out.end());
  }

 private:
  struct Message {
    int connection;
    double time_s;
    std::vector<uint8_t> data;
  };

  static uint64_t time_value(double time_s) {
    const auto sec = static_cast<uint32_t>(time_s);
    const auto nsec = static_cast<uint32_t>((time_s - sec) * 1e9 + 0.5);
    return static_cast<uint64_t>(nsec) << 32 | sec;
  }
  template <typename T>
  static void field(Bytes& b, const std::string& name, T value) {
    b.put<uint32_t>(static_cast<uint32_t>(name.size() + 1 + sizeof(T)));
    b.raw(std::vector<uint8_t>(name.begin(), name.end())).put<char>('=').put<T>(value);
  }
  static void field(Bytes& b, const std::string& name, const std::string& value) {
    const std::string text = name + "=" + value;
    b.string(text);
  }
  static void record(Bytes& out, const Bytes& header, const std::vector<uint8_t>& data) {
    out.put<uint32_t>(static_cast<uint32_t>(header.size())).raw(header.data());
    out.put<uint32_t>(static_cast<uint32_t>(data.size())).raw(data);
  }
  void connection_record(Bytes& out, int c) const {
    Bytes header, data;
    field(header, "op", uint8_t{0x07});
    field(header, "conn", static_cast<int32_t>(c));
    field(header, "topic", connections_[c].first);
    field(data, "topic", connections_[c].first);
    field(data, "type", connections_[c].second);
    field(data, "md5sum", std::string("*"));
    record(out, header, data.data());
  }
  /// The bag header record, padded as rosbag pads it so that rewriting it keeps its size.
  void bag_header(Bytes& out, uint64_t index_pos) const {
    Bytes header;
    field(header, "op", uint8_t{0x03});
    field(header, "index_pos", index_pos);
    field(header, "conn_count", static_cast<int32_t>(connections_.size()));
    field(header, "chunk_count", int32_t{1});
    record(out, header, std::vector<uint8_t>(64, ' '));
  }

  std::vector<std::pair<std::string, std::string>> connections_;
  std::vector<Message> messages_;
};

}  // namespace kfx::io::test
