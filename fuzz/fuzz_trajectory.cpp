/// TUM trajectories: arbitrary text parsed, then evaluated against itself (association,
/// alignment, ATE, checkPos, RPE).

#include "core/platform.hpp"
#include "eval/report.hpp"
#include "fuzz_support.hpp"
#include "io/trajectory.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = kfx::fuzz::write_file("trajectory.txt", data, size);
  try {
    const auto poses = kfx::io::read_tum_trajectory(path);
    kfx::eval::EvalOptions options;
    options.flip_y = size % 2 == 1;
    const auto result = kfx::eval::evaluate_trajectories(poses, poses, options, "a", "b");
    kfx::eval::format_report(result);
    kfx::eval::to_json(result).dump();
  } catch (const kfx::Error&) {
  }
  return 0;
}
