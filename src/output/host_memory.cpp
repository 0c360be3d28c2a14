#include "output/host_memory.hpp"

#include <fstream>
#include <sstream>

#include "core/platform.hpp"
#include "core/volume.hpp"

namespace kfx::output {

size_t volume_host_bytes(int res) {
  const size_t r = static_cast<size_t>(res);
  return r * r * r * sizeof(Voxel);
}

namespace {

/// The value in kB of the line starting with `key` in a /proc file, in bytes; 0 if absent.
size_t proc_kib_field_bytes(const char* path, const std::string& key) {
  std::ifstream file(path);
  std::string line;
  while (std::getline(file, line)) {
    if (line.rfind(key, 0) != 0) continue;
    std::istringstream fields(line.substr(key.size()));
    size_t kib = 0;
    if (fields >> kib) return kib * 1024;
  }
  return 0;
}

}  // namespace

size_t available_host_bytes() { return proc_kib_field_bytes("/proc/meminfo", "MemAvailable:"); }

size_t peak_resident_bytes() { return proc_kib_field_bytes("/proc/self/status", "VmHWM:"); }

void check_host_memory(size_t bytes, const std::string& what) {
  const size_t available = available_host_bytes();
  if (available == 0) return;
  constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;
  KFX_CHECK(bytes < available, what << " needs " << bytes / kGiB << " GiB of host memory, "
                                    << available / kGiB << " GiB are available");
}

}  // namespace kfx::output
