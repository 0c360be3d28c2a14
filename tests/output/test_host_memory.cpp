/// The host memory figures (output/host_memory.hpp): what /proc reports, read back.

#include <gtest/gtest.h>

#include <cstring>
#include <memory>

#include "output/host_memory.hpp"

namespace kfx::output {
namespace {

TEST(HostMemory, PeakResidentGrowsByWhatTheProcessTouches) {
  const size_t before = peak_resident_bytes();
  if (before == 0) GTEST_SKIP() << "no VmHWM in /proc/self/status on this system";
  // 256 MiB written page by page: resident now, so the peak must rise by nearly as much, or the
  // peak already lay that far above (a test run that held more earlier).
  constexpr size_t kBytes = size_t{256} << 20;
  std::unique_ptr<char[]> block(new char[kBytes]);
  std::memset(block.get(), 1, kBytes);
  const size_t after = peak_resident_bytes();
  EXPECT_GE(after, before);
  EXPECT_GE(after, kBytes) << "a process holding 256 MiB reports a peak below it";
  EXPECT_EQ(block[kBytes - 1], 1);
}

TEST(HostMemory, AvailableIsKnownOnLinux) {
  const size_t available = available_host_bytes();
  if (available == 0) GTEST_SKIP() << "no MemAvailable in /proc/meminfo on this system";
  EXPECT_GT(available, size_t{1} << 20);
}

}  // namespace
}  // namespace kfx::output
