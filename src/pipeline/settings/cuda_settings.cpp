/// Settings section `cuda`: the CUDA backend's launch tuning (CudaTuning, backend/backend.hpp),
/// speed only, never results; its rows and checks.

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_cuda(const PipelineConfig& config) {
  const CudaTuning& cuda = config.cuda;
  KFX_CHECK(cuda.reduce_blocks >= 0 && cuda.reduce_blocks <= 65535,
            "cuda_reduce_blocks must be in 0..65535, got " << cuda.reduce_blocks);
  KFX_CHECK(cuda.z_chunks >= 0 && cuda.z_chunks <= 1024,
            "cuda_z_chunks must be in 0..1024, got " << cuda.z_chunks);
}

}  // namespace

SettingsSection cuda_section() {
  // Defaults measured on an H200 (bench/RESULTS.md).
  const std::string s = "cuda";
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_cuda;
  auto& rows = section.fields;
  rows.push_back(on_off_row("cuda_pdl", s,
                            "cuda: programmatic dependent launch on sm_90+ (on|off; speed only)",
                            [](C& c) -> bool& { return c.cuda.pdl; }));
  rows.push_back(integer_row(
      "cuda_reduce_blocks", s,
      "cuda: cap on the ICP reduction grid, 0 = one block per SM (0..65535; it sets the "
      "order of the ICP's sums, so the trajectory's last bits)",
      [](C& c) -> int& { return c.cuda.reduce_blocks; }));
  rows.push_back(integer_row(
      "cuda_z_chunks", s,
      "cuda: z-ranges each integration column is split into, 0 = 4096 / volume resolution "
      "(16 at 256^3, 8 at 512^3) (0..1024; speed only)",
      [](C& c) -> int& { return c.cuda.z_chunks; }));
  rows.push_back(on_off_row(
      "cuda_icp_persistent", s,
      "cuda: each pyramid level's ICP iterations in one cooperative launch with a grid barrier "
      "per iteration (on|off; speed only, the same bits)",
      [](C& c) -> bool& { return c.cuda.icp_persistent; }));
  rows.push_back(on_off_row(
      "cuda_fused_preprocess", s,
      "cuda: mm to m with the bilateral filter in one launch, and every pyramid level's depth, "
      "vertices and normals in one more (on|off; speed only, the same bits)",
      [](C& c) -> bool& { return c.cuda.fused_preprocess; }));
  return section;
}

}  // namespace kfx::settings
