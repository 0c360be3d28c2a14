/// OpenNI2 devices as inputs (`openni2:`): what is said when a device cannot be had. Reading one
/// (an .oni played as a device) is tested from Python (tests/python/test_live_openni.py), where
/// the recordings are written.

#include <gtest/gtest.h>

#include <string>

#include "io/reader.hpp"
#include "support/io_test_support.hpp"

namespace kfx::io::test {
namespace {

TEST(OpenNI2Device, ADeviceThatIsNotThereIsNamed) {
  TempDir dir("kfx_openni2");
  const std::string uri = dir.file("none.oni");
  if (openni2_built()) {
    expect_error([&] { open_reader("openni2:" + uri); },
                 {"OpenNI2 device '" + uri + "'", "not found", "OpenNI2 finds these devices"});
  } else {
    expect_error([&] { open_reader("openni2:" + uri); },
                 {"openni2:" + uri, "built without OpenNI2", "libopenni2-dev"});
  }
}

TEST(OpenNI2Device, OptionsAreCheckedBeforeAnyDeviceIsOpened) {
  expect_error([&] { open_reader("openni2:?rate=60"); },
               {"openni2:?rate=60", "unknown option 'rate'", "real_time=on|off"});
  expect_error([&] { open_reader("openni2:?real_time=maybe"); },
               {"real_time=maybe is neither on nor off"});
  ReaderOptions options;
  options.depth_scale_per_m = 5000.0;
  expect_error([&] { open_reader("openni2:", options); },
               {"a depth scale applies only to PNG depth", "an OpenNI2 device"});
}

}  // namespace
}  // namespace kfx::io::test
