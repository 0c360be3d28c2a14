/// Mesh extraction time (marching cubes: count pass, compaction scan, write pass and the copy to
/// the host, i.e. Backend::extract_mesh() end to end) on an analytic volume at 256³ and 512³:
/// the inside of a box (walls 5 % in from the volume's faces) holding three spheres, observed
/// everywhere, about 5·res² vertices. Run:
///   build/release/bench/kfx_bench_mesh [--backend=cuda] (bench_main.hpp)
/// Figures belong in bench/RESULTS.md with machine, date, commit and command.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>

#include "backend/backend.hpp"
#include "bench_main.hpp"

namespace {

/// Signed distance (metres) to the scene at p: negative inside the walls and the spheres.
float scene_distance_m(float x, float y, float z, float size_m) {
  const float lo = 0.05f * size_m, hi = 0.95f * size_m;
  // Free space is the box's inside: distance to the nearest wall, negative beyond it.
  float d = std::min({x - lo, hi - x, y - lo, hi - y, z - lo, hi - z});
  const float spheres[3][4] = {
      {0.35f, 0.4f, 0.5f, 0.15f}, {0.65f, 0.6f, 0.45f, 0.2f}, {0.5f, 0.75f, 0.7f, 0.1f}};
  for (const auto& s : spheres) {
    const float dx = x - s[0] * size_m, dy = y - s[1] * size_m, dz = z - s[2] * size_m;
    d = std::min(d, std::sqrt(dx * dx + dy * dy + dz * dz) - s[3] * size_m);
  }
  return d;
}

/// A mesher (token-sized images) holding the analytic volume at `res`.
kfx::Backend& mesher(int res) {
  static std::map<int, std::unique_ptr<kfx::Backend>> backends;
  auto& backend = backends[res];
  if (backend) return *backend;
  const float size_m = 4.0f, mu_m = 0.1f;
  std::vector<kfx::Voxel> voxels(static_cast<size_t>(res) * res * res);
  const float voxel_m = size_m / res;
#pragma omp parallel for schedule(static)
  for (int z = 0; z < res; ++z) {
    for (int y = 0; y < res; ++y) {
      for (int x = 0; x < res; ++x) {
        const float d = scene_distance_m((x + 0.5f) * voxel_m, (y + 0.5f) * voxel_m,
                                         (z + 0.5f) * voxel_m, size_m);
        const float t = std::max(-1.0f, std::min(1.0f, d / mu_m));
        voxels[x + static_cast<size_t>(y) * res + static_cast<size_t>(z) * res * res] =
            kfx::Voxel{static_cast<int16_t>(t * kfx::kTsdfScale), 10};
      }
    }
  }
  kfx::BackendSetup setup;
  setup.input_width_px = 8;
  setup.input_height_px = 8;
  setup.compute_ratio = 1;
  setup.pyramid_levels = 1;
  setup.volume_res_vox = res;
  setup.volume_size_m = size_m;
  backend = kfx::make_backend(kfx::parse_backend_kind(kfx::bench::backend_name()), setup);
  backend->upload_volume(voxels);
  backend->extract_mesh();  // warm-up: scratch allocated, pages touched
  return *backend;
}

void BM_ExtractMesh(benchmark::State& state) {
  kfx::Backend& backend = mesher(static_cast<int>(state.range(0)));
  size_t vertices = 0, triangles = 0;
  for (auto _ : state) {
    const kfx::MeshView mesh = backend.extract_mesh();
    vertices = mesh.vertex_count;
    triangles = mesh.triangle_count;
  }
  state.counters["vertices"] = static_cast<double>(vertices);
  state.counters["triangles"] = static_cast<double>(triangles);
  state.SetLabel(backend.name() + ": " + backend.device_name());
}
BENCHMARK(BM_ExtractMesh)->Arg(256)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
