#include "bench_main.hpp"

#include <benchmark/benchmark.h>

#include <cstring>

namespace kfx::bench {
namespace {
std::string g_backend = "cpu";
}  // namespace

const std::string& backend_name() { return g_backend; }

}  // namespace kfx::bench

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--backend=", 10) == 0) kfx::bench::g_backend = argv[i] + 10;
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
