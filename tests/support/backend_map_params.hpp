#pragma once
/// Test parameters for behaviour every backend and every map kind share: the cross product
/// {cpu, cuda} × {dense, blocks}, each case named `backend_map` (cpu_dense, cuda_blocks, ...) so
/// that a failing case says where it failed. A CUDA case skips, with the reason (no CUDA device,
/// or a build without the CUDA backend), where cuda_available() is false, so the same test list
/// runs on a CPU-only machine and on a GPU one.
///
/// Use: derive the fixture from BackendMapTest (or use it as is), write TEST_P(Fixture, Name),
/// and instantiate once with KFX_INSTANTIATE_BACKEND_MAP_TESTS(Fixture).

#include <gtest/gtest.h>

#include <ostream>
#include <string>
#include <vector>

#include "backend/backend.hpp"
#include "kfx/settings.hpp"

namespace kfx::test {

/// One case: a backend ("cpu", "cuda") and a map kind ("dense", "blocks"), spelled as the
/// settings `backend` and `volume` spell them.
struct BackendMap {
  std::string backend;
  std::string map;
  bool cuda() const { return backend == "cuda"; }
  bool blocks() const { return map == "blocks"; }
  BackendKind backend_kind() const { return cuda() ? BackendKind::kCuda : BackendKind::kCpu; }
  MapKind map_kind() const { return blocks() ? MapKind::kBlocks : MapKind::kDense; }
};

/// How gtest prints a case in a failure's message: `cpu_dense`, ...
inline void PrintTo(const BackendMap& c, std::ostream* out) { *out << c.backend << "_" << c.map; }

/// Every case, the CPU's first (they run wherever the tests run).
inline std::vector<BackendMap> all_backend_maps() {
  return {{"cpu", "dense"}, {"cpu", "blocks"}, {"cuda", "dense"}, {"cuda", "blocks"}};
}

/// gtest's name for a case: `cpu_dense`, `cuda_blocks`, ...
inline std::string backend_map_name(const ::testing::TestParamInfo<BackendMap>& info) {
  return info.param.backend + "_" + info.param.map;
}

/// A fixture whose CUDA cases skip, saying why, where no CUDA device can be used.
class BackendMapTest : public ::testing::TestWithParam<BackendMap> {
 protected:
  void SetUp() override {
    std::string why_not;
    if (GetParam().cuda() && !cuda_available(&why_not)) GTEST_SKIP() << "CUDA case: " << why_not;
  }

  /// The public API's settings for this case: the exact preset on the case's backend and map
  /// kind, a `volume_resolution`-voxel cube (or blocks of the same voxel size), and a block
  /// budget small enough to allocate at once in a test (64 MiB; only set for blocks, where the
  /// setting acts, so that the dense case sees no inert-setting warning).
  Settings settings(int volume_resolution = 64) const {
    Settings s;
    s.backend(GetParam().backend)
        .set("volume", GetParam().map)
        .set("volume_resolution", std::to_string(volume_resolution));
    if (GetParam().blocks()) s.set("map_budget_mb", "64");
    return s;
  }
};

}  // namespace kfx::test

/// Instantiates `fixture`'s TEST_Ps over every backend × map kind.
#define KFX_INSTANTIATE_BACKEND_MAP_TESTS(fixture)                               \
  INSTANTIATE_TEST_SUITE_P(BackendsAndMaps, fixture,                             \
                           ::testing::ValuesIn(::kfx::test::all_backend_maps()), \
                           ::kfx::test::backend_map_name)
