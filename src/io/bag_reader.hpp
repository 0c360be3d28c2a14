#pragma once
/// Internal: recordings (ROS 1 bags, RealSense bags, ROS 2 bags) as readers, and the choice of
/// their topics. open_reader() dispatches here; callers outside src/io/ use open_reader().

#include <memory>
#include <string>

#include "io/bag_container.hpp"
#include "io/reader.hpp"

namespace kfx::io {

/// Which topics of a recording to read; empty fields are chosen automatically where that is
/// unambiguous (the one depth image topic, the one colour image topic, their CameraInfo).
struct BagTopics {
  std::string depth;        ///< a sensor_msgs/Image topic holding 16UC1, mono16 or 32FC1 depth
  std::string colour;       ///< a sensor_msgs/Image topic holding rgb8, bgr8, rgba8 or bgra8
  std::string depth_info;   ///< the depth camera's sensor_msgs/CameraInfo topic
  std::string colour_info;  ///< the colour camera's sensor_msgs/CameraInfo topic
  bool no_colour = false;   ///< colour=none: read depth only
};

/// Parses an input's topic choice, the part after '?' in `bag?depth=/a&colour=/b` (keys depth,
/// colour, depth_info, colour_info; colour=none reads depth only). Throws kfx::Error naming
/// `input` on an unknown key or a malformed pair.
BagTopics parse_bag_topics(const std::string& query, const std::string& input);

/// The frames of a recording: depth (converted to millimetres with the recording's depth
/// scale: RealSense's Depth Units, else ROS's millimetres for 16-bit and metres for 32FC1),
/// colour paired with each depth image by time and resampled to its size, intrinsics from the
/// CameraInfo, and for RealSense bags the depth-to-colour extrinsic. Throws kfx::Error naming
/// the file, topic and message when there is no depth topic, several, an unknown encoding, or
/// no intrinsics.
std::unique_ptr<Reader> open_bag_reader(std::unique_ptr<BagContainer> bag, const BagTopics& topics,
                                        const ReaderOptions& options);

/// True when `path` is a rosbag2 folder (a metadata.yaml of rosbag2, or a .db3 or .mcap file
/// in it).
bool is_ros2_bag_folder(const std::string& path);

}  // namespace kfx::io
