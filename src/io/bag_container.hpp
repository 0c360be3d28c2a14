#pragma once
/// Internal: a recording's topics and messages, whatever holds them (a ROS 1 bag, RealSense's
/// bags included, or a ROS 2 bag's sqlite3 database). bag_reader.cpp turns one into frames.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "io/ros_messages.hpp"

namespace kfx::io {

/// One topic: its name and message type, spelt the ROS 1 way ("sensor_msgs/Image").
struct BagTopic {
  std::string name;
  std::string type;
};

/// Where one message lies; only the container that listed it can read it.
struct BagMessage {
  int64_t time_ns = 0;    ///< the time it was recorded
  uint64_t location = 0;  ///< container-specific: chunk index (ROS 1) or row id (ROS 2)
  uint32_t offset = 0;    ///< container-specific: byte offset inside the chunk (ROS 1)
};

/// The messages of a recording, read on demand.
class BagContainer {
 public:
  virtual ~BagContainer() = default;
  /// The file (or folder) it was opened from, for messages.
  virtual const std::string& path() const = 0;
  /// How its messages are serialised.
  virtual RosEncoding encoding() const = 0;
  /// Every topic that holds at least one message.
  virtual std::vector<BagTopic> topics() const = 0;
  /// The messages of `topic`, oldest first (empty for an unknown topic).
  virtual std::vector<BagMessage> messages(const std::string& topic) const = 0;
  /// One message's bytes. Throws kfx::Error naming the file and `topic` when it cannot be read
  /// (truncated, a compression kfx was built without, a corrupt chunk).
  virtual std::vector<uint8_t> read(const BagMessage& message, const std::string& topic) = 0;
};

/// Opens a ROS 1 bag (format 2.0; RealSense's `.bag` files are such bags). Throws kfx::Error
/// naming the file when it is not a bag, is truncated or unindexed.
std::unique_ptr<BagContainer> open_ros1_bag(const std::string& path);

/// Opens a ROS 2 bag: a rosbag2 folder (metadata.yaml and a .db3 file) or one .db3 file. Throws
/// kfx::Error naming it when it cannot be read, or when kfx was built without sqlite3.
std::unique_ptr<BagContainer> open_ros2_bag(const std::string& path);

}  // namespace kfx::io
