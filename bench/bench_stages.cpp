/// Per-stage micro-benchmarks of a backend on a synthetic frame (a tilted plane and a box in
/// front of it), 320×240 compute, 256³ volume. Run: build/release/bench/kfx_bench_stages
/// [--backend=cuda]. CPU by default; the figures belong in bench/RESULTS.md with machine, date,
/// commit and command.

#include <benchmark/benchmark.h>

#include <cstring>
#include <memory>
#include <string>

#include "bench_main.hpp"
#include "pipeline/pipeline.hpp"

namespace {

/// A 640×480 depth frame: a plane 2.5 m away tilted in x, a box 1.5 m away in the middle.
kfx::HostImage<uint16_t> make_frame() {
  kfx::HostImage<uint16_t> depth(640, 480);
  for (int y = 0; y < 480; ++y) {
    for (int x = 0; x < 640; ++x) {
      double z = 2.5 + 0.001 * (x - 320);
      if (x > 220 && x < 420 && y > 140 && y < 340) z = 1.5;
      depth(x, y) = static_cast<uint16_t>(z * 1000.0);
    }
  }
  return depth;
}

struct Fixture {
  std::unique_ptr<kfx::Pipeline> pipeline;
  kfx::HostImage<uint16_t> frame = make_frame();
  Fixture() {
    kfx::PipelineConfig config;
    config.volume.size_m = 4.0f;
    config.integration.rate = 1;
    pipeline =
        std::make_unique<kfx::Pipeline>(config, kfx::Intrinsics{525, 525, 319.5f, 239.5f}, 640, 480,
                                        kfx::parse_backend_kind(kfx::bench::backend_name()));
    for (int i = 0; i < 6; ++i) pipeline->process(frame);  // tracked frames from frame 4 on
  }
};

void report_stages(benchmark::State& state, const char* stage_filter) {
  static Fixture fixture;
  double stage_sum_ms[static_cast<int>(kfx::Stage::kCount)] = {};
  int frames = 0;
  for (auto _ : state) {
    const kfx::FrameReport r = fixture.pipeline->process(fixture.frame);
    for (int s = 0; s < static_cast<int>(kfx::Stage::kCount); ++s) stage_sum_ms[s] += r.stage_ms[s];
    ++frames;
  }
  for (int s = 0; s < static_cast<int>(kfx::Stage::kCount); ++s) {
    const char* name = kfx::stage_name(static_cast<kfx::Stage>(s));
    if (stage_filter && std::strcmp(stage_filter, name) != 0) continue;
    state.counters[std::string(name) + "_ms"] = stage_sum_ms[s] / frames;
  }
}

void BM_Frame(benchmark::State& state) { report_stages(state, nullptr); }
BENCHMARK(BM_Frame)->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace
