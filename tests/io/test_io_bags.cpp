/// Recordings as inputs (issue 46): ROS 1 bags built byte by byte, good and bad. A bad recording
/// (truncated, unindexed, no depth topic, an unknown encoding, no intrinsics) fails with a message
/// naming the file, the topic and the message.

#include <gtest/gtest.h>

#include <cmath>

#include "io/reader.hpp"
#include "support/bag_test_support.hpp"
#include "support/io_test_support.hpp"

namespace kfx::io::test {
namespace {

constexpr uint32_t kW = 4, kH = 3;

std::vector<uint16_t> depth_mm(uint16_t base) {
  std::vector<uint16_t> mm(kW * kH);
  for (size_t i = 0; i < mm.size(); ++i) mm[i] = static_cast<uint16_t>(base + i);
  return mm;
}

std::vector<uint8_t> colour_bytes(uint8_t base, int channels) {
  std::vector<uint8_t> px(kW * kH * channels);
  for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>(base + i);
  return px;
}

/// A ROS camera's bag: depth (16UC1) and colour (rgb8) with their CameraInfo, `frames` frames.
Ros1BagBuilder camera_bag(int frames = 2, bool with_info = true, bool with_colour = true) {
  Ros1BagBuilder bag;
  const int depth = bag.connection("/camera/depth/image_raw", "sensor_msgs/Image");
  const int info =
      with_info ? bag.connection("/camera/depth/camera_info", "sensor_msgs/CameraInfo") : -1;
  const int colour =
      with_colour ? bag.connection("/camera/color/image_raw", "sensor_msgs/Image") : -1;
  for (int f = 0; f < frames; ++f) {
    const double t = 10.0 + f / 30.0;
    if (info >= 0) bag.message(info, t, ros1_camera_info(kW, kH, 2.5, 2.0, 1.5, 1.0));
    bag.message(depth, t, ros1_depth(t, kW, kH, depth_mm(static_cast<uint16_t>(1000 + 100 * f))));
    if (colour >= 0) {
      bag.message(colour, t, ros1_image(t, kW, kH, "rgb8", 3, colour_bytes(10 * f, 3)));
    }
  }
  return bag;
}

std::string write_bag(const TempDir& dir, const Ros1BagBuilder& bag, bool indexed = true,
                      const std::string& name = "camera.bag") {
  const std::string path = dir.file(name);
  write_bytes(path, bag.bytes(indexed));
  return path;
}

TEST(RosBag, ReadsDepthColourStampsAndIntrinsics) {
  TempDir dir("kfx_bag");
  const std::string path = write_bag(dir, camera_bag());
  auto reader = open_reader(path);
  EXPECT_EQ(reader->width_px(), static_cast<int>(kW));
  EXPECT_EQ(reader->height_px(), static_cast<int>(kH));
  EXPECT_EQ(reader->frame_count(), 2);
  EXPECT_TRUE(reader->has_colour());
  ASSERT_TRUE(reader->default_intrinsics().has_value());
  EXPECT_EQ(reader->default_intrinsics()->fx, 2.5f);
  EXPECT_EQ(reader->default_intrinsics()->fy, 2.0f);
  EXPECT_EQ(reader->default_intrinsics()->cx, 1.5f);
  EXPECT_EQ(reader->default_intrinsics()->cy, 1.0f);
  EXPECT_NE(reader->intrinsics_source().find("/camera/depth/camera_info"), std::string::npos);
  EXPECT_NE(reader->description().find("/camera/depth/image_raw"), std::string::npos);
  EXPECT_TRUE(reader->recommended_settings().empty());  // registered colour, same camera
  for (int f = 0; f < 2; ++f) {
    const Frame frame = expect_ok_frame(*reader);
    EXPECT_EQ(frame.index, f);
    EXPECT_NEAR(frame.stamp_s, 10.0 + f / 30.0, 1e-9);
    EXPECT_EQ(frame.depth_mm(0, 0), 1000 + 100 * f);
    EXPECT_EQ(frame.depth_mm(3, 2), 1000 + 100 * f + 11);
    ASSERT_EQ(frame.rgb.width(), static_cast<int>(kW));
    EXPECT_EQ(frame.rgb(1, 0).r, 10 * f + 3);
    EXPECT_EQ(frame.rgb(1, 0).g, 10 * f + 4);
    EXPECT_EQ(frame.rgb(1, 0).b, 10 * f + 5);
  }
  expect_end(*reader);
}

TEST(RosBag, ConvertsBgrColourFloatDepthAndResamplesColourToTheDepthSize) {
  TempDir dir("kfx_bag");
  Ros1BagBuilder bag;
  const int depth = bag.connection("/cam/depth/image", "sensor_msgs/Image");
  const int info = bag.connection("/cam/depth/camera_info", "sensor_msgs/CameraInfo");
  const int colour = bag.connection("/cam/rgb/image", "sensor_msgs/Image");
  const int colour_info = bag.connection("/cam/rgb/camera_info", "sensor_msgs/CameraInfo");
  std::vector<float> metres(kW * kH, 1.2345f);
  metres[0] = std::nanf("");
  std::vector<uint8_t> pixels(metres.size() * 4);
  std::memcpy(pixels.data(), metres.data(), pixels.size());
  bag.message(info, 1.0, ros1_camera_info(kW, kH, 2.5, 2.0, 1.5, 1.0));
  bag.message(colour_info, 1.0, ros1_camera_info(2 * kW, 2 * kH, 6.0, 4.0, 3.5, 2.5));
  bag.message(depth, 1.0, ros1_image(1.0, kW, kH, "32FC1", 4, pixels));
  // Colour at twice the depth's size, BGR: pixel (2x, 2y) lands on depth pixel (x, y).
  std::vector<uint8_t> bgr(2 * kW * 2 * kH * 3);
  for (size_t i = 0; i < bgr.size(); ++i) bgr[i] = static_cast<uint8_t>(i);
  bag.message(colour, 1.0, ros1_image(1.0, 2 * kW, 2 * kH, "bgr8", 3, bgr));
  auto reader = open_reader(write_bag(dir, bag));
  const Frame frame = expect_ok_frame(*reader);
  EXPECT_EQ(frame.depth_mm(0, 0), 0);  // NaN: no measurement
  EXPECT_EQ(frame.depth_mm(1, 0), 1235);
  const size_t src = ((2 * 1) * (2 * kW) + 2 * 1) * 3;  // colour (2, 2) for depth (1, 1)
  EXPECT_EQ(frame.rgb(1, 1).r, bgr[src + 2]);
  EXPECT_EQ(frame.rgb(1, 1).b, bgr[src]);
  // The colour camera, scaled to the depth size, differs from the depth camera: its settings.
  const auto settings = reader->recommended_settings();
  ASSERT_EQ(settings.size(), 2u);
  EXPECT_EQ(settings[0].first, "colour_camera");
  EXPECT_EQ(settings[0].second, "3,2,1.5,1");  // (6, 4, 3.5, 2.5) at twice the size
  EXPECT_EQ(settings[1], (std::pair<std::string, std::string>{"colour_extrinsic", "0,0,0,0,0,0"}));
}

TEST(RosBag, RealSenseDepthUnitsAndExtrinsicComeFromTheFile) {
  TempDir dir("kfx_bag");
  Ros1BagBuilder bag;
  const std::string d = "/device_0/sensor_0/Depth_0", c = "/device_0/sensor_1/Color_0";
  const int depth = bag.connection(d + "/image/data", "sensor_msgs/Image");
  const int info = bag.connection(d + "/info/camera_info", "sensor_msgs/CameraInfo");
  const int units =
      bag.connection("/device_0/sensor_0/option/Depth Units/value", "std_msgs/Float32");
  const int depth_tf = bag.connection(d + "/tf/0", "geometry_msgs/Transform");
  const int colour = bag.connection(c + "/image/data", "sensor_msgs/Image");
  const int colour_tf = bag.connection(c + "/tf/0", "geometry_msgs/Transform");
  const int colour_info = bag.connection(c + "/info/camera_info", "sensor_msgs/CameraInfo");
  bag.message(colour_info, 1.0, ros1_camera_info(kW, kH, 2.5, 2.0, 1.5, 1.0));
  Bytes quarter_mm;
  quarter_mm.put<float>(0.00025f);
  bag.message(units, 0.0, quarter_mm.data());
  // Depth at the reference; the colour camera sees it 15 mm along x, turned 90° about z.
  Bytes identity, turned;
  for (double v : {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0}) identity.put<double>(v);
  for (double v : {0.015, 0.0, 0.0, 0.0, 0.0, std::sqrt(0.5), std::sqrt(0.5)})
    turned.put<double>(v);
  bag.message(depth_tf, 0.0, identity.data());
  bag.message(colour_tf, 0.0, turned.data());
  bag.message(info, 1.0, ros1_camera_info(kW, kH, 2.5, 2.0, 1.5, 1.0));
  bag.message(depth, 1.0, ros1_depth(1.0, kW, kH, depth_mm(4000), "mono16"));
  bag.message(colour, 1.0, ros1_image(1.0, kW, kH, "rgb8", 3, colour_bytes(0, 3)));
  auto reader = open_reader(write_bag(dir, bag));
  EXPECT_NE(reader->description().find("RealSense"), std::string::npos);
  const Frame frame = expect_ok_frame(*reader);
  EXPECT_EQ(frame.depth_mm(0, 0), 1000);  // 4000 units of 0.25 mm
  EXPECT_EQ(frame.depth_mm(2, 0), 1001);  // 4002 × 0.25 = 1000.5, rounded
  // Each tf maps the reference (here the depth camera) into its stream: the colour camera's
  // is the depth camera's pose in the colour frame.
  const auto settings = reader->recommended_settings();
  ASSERT_EQ(settings.size(), 2u);
  EXPECT_EQ(settings[0].second, "2.5,2,1.5,1");
  EXPECT_EQ(settings[1].first, "colour_extrinsic");
  double e[6];
  ASSERT_EQ(std::sscanf(settings[1].second.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf", &e[0], &e[1], &e[2],
                        &e[3], &e[4], &e[5]),
            6);
  EXPECT_NEAR(e[0], 0.015, 1e-9);
  EXPECT_NEAR(e[1], 0.0, 1e-9);
  EXPECT_NEAR(e[2], 0.0, 1e-9);
  EXPECT_NEAR(e[3], 0.0, 1e-9);
  EXPECT_NEAR(e[4], 0.0, 1e-9);
  EXPECT_NEAR(e[5], M_PI / 2, 1e-6);
}

TEST(RosBag, TruncatedBagNamesTheFile) {
  TempDir dir("kfx_bag");
  std::vector<char> bytes = camera_bag().bytes();
  bytes.resize(bytes.size() / 2);
  const std::string path = dir.file("cut.bag");
  write_bytes(path, bytes);
  expect_error([&] { open_reader(path); }, {"ROS bag '" + path + "'", "truncated"});
}

TEST(RosBag, TruncatedInsideTheIndexNamesTheFile) {
  TempDir dir("kfx_bag");
  std::vector<char> bytes = camera_bag().bytes();
  bytes.resize(bytes.size() - 10);
  const std::string path = dir.file("cut.bag");
  write_bytes(path, bytes);
  expect_error([&] { open_reader(path); }, {"ROS bag '" + path + "'", "truncated"});
}

TEST(RosBag, UnindexedBagSaysHowToRepairIt) {
  TempDir dir("kfx_bag");
  const std::string path = write_bag(dir, camera_bag(), false);
  expect_error([&] { open_reader(path); }, {path, "unindexed", "rosbag reindex"});
}

TEST(RosBag, NotABagAndAnotherVersionAreRefused) {
  TempDir dir("kfx_bag");
  const std::string other = dir.file("old.bag");
  write_text(other, "#ROSBAG V1.2\nwhatever follows");
  expect_error([&] { open_reader(other); }, {other, "version", "2.0"});
  const std::string text = dir.file("notes.bag");
  write_text(text, "not a bag at all");
  expect_error([&] { open_reader(text); }, {text, "is not a ROS bag"});
}

TEST(RosBag, NoDepthTopicListsTheImageTopics) {
  TempDir dir("kfx_bag");
  Ros1BagBuilder bag;
  const int colour = bag.connection("/camera/color/image_raw", "sensor_msgs/Image");
  bag.message(colour, 1.0, ros1_image(1.0, kW, kH, "rgb8", 3, colour_bytes(0, 3)));
  const std::string path = write_bag(dir, bag);
  expect_error([&] { open_reader(path); },
               {path, "has no depth topic", "/camera/color/image_raw", "?depth=/topic"});
}

TEST(RosBag, UnknownDepthEncodingNamesTheTopicAndMessage) {
  TempDir dir("kfx_bag");
  Ros1BagBuilder bag;
  const int depth = bag.connection("/camera/depth/image_raw", "sensor_msgs/Image");
  bag.message(depth, 1.0, ros1_image(1.0, kW, kH, "8UC1", 1, colour_bytes(0, 1)));
  const std::string path = write_bag(dir, bag);
  // Not recognised as depth automatically, and refused when named.
  expect_error([&] { open_reader(path); }, {path, "has no depth topic"});
  expect_error(
      [&] { open_reader(path + "?depth=/camera/depth/image_raw"); },
      {path, "topic '/camera/depth/image_raw'", "first message", "unknown depth encoding '8UC1'"});
}

TEST(RosBag, MissingIntrinsicsNameTheDepthTopic) {
  TempDir dir("kfx_bag");
  const std::string path = write_bag(dir, camera_bag(2, false));
  expect_error([&] { open_reader(path); },
               {path, "intrinsics missing", "'/camera/depth/image_raw'", "?depth_info=/topic"});
  // A CameraInfo whose K is all zero (an uncalibrated driver) is no intrinsics either.
  Ros1BagBuilder bag;
  const int depth = bag.connection("/camera/depth/image_raw", "sensor_msgs/Image");
  const int info = bag.connection("/camera/depth/camera_info", "sensor_msgs/CameraInfo");
  bag.message(info, 1.0, ros1_camera_info(kW, kH, 0, 0, 0, 0));
  bag.message(depth, 1.0, ros1_depth(1.0, kW, kH, depth_mm(1000)));
  const std::string zero = write_bag(dir, bag, true, "zero.bag");
  expect_error([&] { open_reader(zero); },
               {zero, "topic '/camera/depth/camera_info'", "intrinsics missing"});
}

TEST(RosBag, SeveralDepthTopicsMustBeNamed) {
  TempDir dir("kfx_bag");
  Ros1BagBuilder bag;
  for (const std::string ns : {"/left", "/right"}) {
    const int depth = bag.connection(ns + "/depth/image_raw", "sensor_msgs/Image");
    const int info = bag.connection(ns + "/depth/camera_info", "sensor_msgs/CameraInfo");
    bag.message(info, 1.0, ros1_camera_info(kW, kH, ns == "/left" ? 2.5 : 3.5, 2.0, 1.5, 1.0));
    bag.message(depth, 1.0, ros1_depth(1.0, kW, kH, depth_mm(1000)));
  }
  const std::string path = write_bag(dir, bag);
  expect_error([&] { open_reader(path); },
               {path, "several depth topics", "/left/depth/image_raw", "/right/depth/image_raw"});
  auto right = open_reader(path + "?depth=/right/depth/image_raw");
  EXPECT_EQ(right->default_intrinsics()->fx, 3.5f);
  expect_error([&] { open_reader(path + "?depth=/right/depth/image_raw&what=1"); },
               {"unknown key 'what'"});
}

TEST(RosBag, AMessageShorterThanItsImageIsABadFrameNamingIt) {
  TempDir dir("kfx_bag");
  Ros1BagBuilder bag;
  const int depth = bag.connection("/camera/depth/image_raw", "sensor_msgs/Image");
  const int info = bag.connection("/camera/depth/camera_info", "sensor_msgs/CameraInfo");
  bag.message(info, 1.0, ros1_camera_info(kW, kH, 2.5, 2.0, 1.5, 1.0));
  bag.message(depth, 1.0, ros1_depth(1.0, kW, kH, depth_mm(1000)));
  std::vector<uint16_t> short_depth = depth_mm(1000);
  short_depth.resize(5);
  bag.message(depth, 2.0, ros1_depth(2.0, kW, kH, short_depth));
  bag.message(depth, 3.0, ros1_depth(3.0, kW, kH, depth_mm(1000)));
  const std::string path = write_bag(dir, bag);
  auto reader = open_reader(path);
  expect_ok_frame(*reader);
  expect_bad_frame(*reader,
                   {path, "topic '/camera/depth/image_raw'", "message 1", "10 data bytes"});
  expect_ok_frame(*reader);  // later frames are fine
  expect_end(*reader);
}

TEST(RosBag, ColourTooFarInTimeIsABadFrame) {
  TempDir dir("kfx_bag");
  Ros1BagBuilder bag;
  const int depth = bag.connection("/camera/depth/image_raw", "sensor_msgs/Image");
  const int info = bag.connection("/camera/depth/camera_info", "sensor_msgs/CameraInfo");
  const int colour = bag.connection("/camera/color/image_raw", "sensor_msgs/Image");
  bag.message(info, 1.0, ros1_camera_info(kW, kH, 2.5, 2.0, 1.5, 1.0));
  bag.message(depth, 1.0, ros1_depth(1.0, kW, kH, depth_mm(1000)));
  bag.message(colour, 1.0, ros1_image(1.0, kW, kH, "rgb8", 3, colour_bytes(0, 3)));
  bag.message(depth, 2.0, ros1_depth(2.0, kW, kH, depth_mm(1000)));
  const std::string path = write_bag(dir, bag);
  auto reader = open_reader(path);
  expect_ok_frame(*reader);
  expect_bad_frame(*reader, {path, "no colour image within", "'/camera/color/image_raw'"});
}

TEST(RosBag, ABagIsKnownByItsContentsWhateverItsName) {
  TempDir dir("kfx_bag");
  const std::string path = write_bag(dir, camera_bag(), true, "camera.dat");
  EXPECT_EQ(open_reader(path)->frame_count(), 2);
}

TEST(RosBag, AForeignOniAndAnMcapRecordingSayWhatIsWrong) {
  TempDir dir("kfx_bag");
  // Not a recording OpenNI2's player opens (or kfx was built without OpenNI2): the file named,
  // and OpenNI2.
  const std::string oni = dir.file("room.oni");
  write_text(oni, "ONI whatever");
  expect_error([&] { open_reader(oni); }, {oni, "OpenNI2"});
  const std::string mcap = dir.file("room.mcap");
  write_text(mcap, "\x89MCAP0\r\n");
  expect_error([&] { open_reader(mcap); }, {mcap, "mcap", "convert it"});
}

TEST(RosBag, TopicChoiceOnAnythingButARecordingIsRefused) {
  TempDir dir("kfx_bag");
  const std::string raw = dir.file("x.raw");
  write_text(raw, "");
  expect_error([&] { open_reader(raw + "?depth=/a"); }, {"applies only to recordings"});
}

}  // namespace
}  // namespace kfx::io::test
