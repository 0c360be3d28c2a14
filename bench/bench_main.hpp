#pragma once
/// The `main` every kfx benchmark driver shares (bench_main.cpp): `--backend=cpu|cuda|auto`
/// picks the backend the benchmarks run on (cpu by default); the other arguments go to Google
/// Benchmark.

#include <string>

namespace kfx::bench {

/// The backend named by --backend= ("cpu" unless given).
const std::string& backend_name();

}  // namespace kfx::bench
