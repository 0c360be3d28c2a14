// Tests of swapping a block map's far blocks to host memory (map/block_swap.hpp, settings
// map_swap and map_swap_distance_m): the voxel merge, the union of two maps, one pass's moves,
// and a run on the synthetic house that swaps and gives the same bytes as one that never does.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "backend/backend.hpp"
#include "core/mesh.hpp"
#include "core/platform.hpp"
#include "io/synthetic.hpp"
#include "map/block_swap.hpp"
#include "pipeline/config.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx {
namespace {

/// A contents of 1 cm voxels with one block per key in `keys` (increasing), voxel v of block i
/// holding tsdf 100·i + v % 7 and weight i + 1.
BlockMapContents blocks_at(const std::vector<uint64_t>& keys, bool colour = false) {
  BlockMapContents c;
  c.grid_res = 1;
  c.grid_size_m = 0.01f;
  for (size_t i = 0; i < keys.size(); ++i) {
    c.keys.push_back(keys[i]);
    for (int v = 0; v < kBlockVoxels; ++v) {
      c.voxels.push_back(Voxel{static_cast<int16_t>(100 * i + v % 7), static_cast<int16_t>(i + 1)});
      if (colour) c.colours.push_back(ColourVoxel{100, 200, 300, 2});
    }
  }
  return c;
}

TEST(BlockSwap, MergedVoxelIsTheWeightedMeanOfBoth) {
  // 3 measurements averaging 100 and 1 of 200: 4 measurements averaging 125.
  const Voxel m = merge_voxel(Voxel{100, 3}, Voxel{200, 1}, 100);
  EXPECT_EQ(m.tsdf, 125);
  EXPECT_EQ(m.weight, 4);
  // Rounded to the nearest stored value: (2·10 + 1·11) / 3 = 10.33 → 10; (1·10 + 2·11) / 3 → 11.
  EXPECT_EQ(merge_voxel(Voxel{10, 2}, Voxel{11, 1}, 100).tsdf, 10);
  EXPECT_EQ(merge_voxel(Voxel{10, 1}, Voxel{11, 2}, 100).tsdf, 11);
  // The weight is capped as integration caps it.
  EXPECT_EQ(merge_voxel(Voxel{0, 90}, Voxel{0, 30}, 100).weight, 100);
  // A voxel of weight 0 (never measured) adds nothing, whatever its tsdf.
  const Voxel empty{32767, 0};
  EXPECT_EQ(merge_voxel(Voxel{-500, 7}, empty, 100).tsdf, -500);
  EXPECT_EQ(merge_voxel(empty, Voxel{-500, 7}, 100).weight, 7);
}

TEST(BlockSwap, MergedColourIsTheWeightedMeanOfBoth) {
  const ColourVoxel m = merge_colour(ColourVoxel{0, 300, 1000, 1}, ColourVoxel{400, 300, 0, 3}, 3);
  EXPECT_EQ(m.r, 300);
  EXPECT_EQ(m.g, 300);
  EXPECT_EQ(m.b, 250);
  EXPECT_EQ(m.weight, 3);  // capped
  EXPECT_EQ(merge_colour(ColourVoxel{1, 2, 3, 0}, ColourVoxel{7, 8, 9, 2}, 100).r, 7);
}

TEST(BlockSwap, UnionKeepsKeyOrderAndMergesSharedBlocks) {
  const BlockMapContents a = blocks_at({2, 5, 9}, true);
  const BlockMapContents b = blocks_at({1, 5, 12});  // no colour
  const BlockMapContents u = merge_contents(a, b, VoxelWeightCaps{});
  EXPECT_EQ(u.keys, (std::vector<uint64_t>{1, 2, 5, 9, 12}));
  ASSERT_EQ(u.voxels.size(), 5u * kBlockVoxels);
  ASSERT_EQ(u.colours.size(), u.voxels.size());
  // Key 1 is b's block 0 (no colour yet); key 5 merges a's block 1 (weight 2, tsdf 100 + v%7)
  // with b's block 1 (weight 2, the same values): the same tsdf, weight 4, a's colour.
  EXPECT_EQ(u.voxels[0].tsdf, 0);
  EXPECT_EQ(u.colours[0].weight, 0);
  const size_t k5 = 2 * kBlockVoxels;
  for (int v = 0; v < kBlockVoxels; ++v) {
    EXPECT_EQ(u.voxels[k5 + v].tsdf, 100 + v % 7);
    EXPECT_EQ(u.voxels[k5 + v].weight, 4);
  }
  EXPECT_EQ(u.colours[k5].r, 100);
  EXPECT_EQ(u.colours[k5].weight, 2);
}

TEST(BlockSwap, PassMovesFarBlocksOutAndNearOnesBack) {
  // Blocks of 8 cm along x at block coordinates 0, 5, 10, ..., 45 (centres 4 cm, 44 cm, ...,
  // 3.64 m).
  std::vector<uint64_t> keys;
  for (int i = 0; i < 10; ++i) keys.push_back(pack_block_key(5 * i, 0, 0));
  std::sort(keys.begin(), keys.end());
  const BlockMapContents map = blocks_at(keys);
  const float voxel_m = 0.01f;
  auto distance = [&](uint64_t key, Vec3f p) { return block_centre_distance_m(key, voxel_m, p); };
  EXPECT_NEAR(distance(pack_block_key(5, 0, 0), Vec3f{0, 0.04f, 0.04f}), 0.44f, 1e-6f);

  BlockSwapStore store;
  BlockMapContents active = map;
  const Vec3f camera{0.04f, 0.04f, 0.04f};
  // Everything within 4 m: nothing moves.
  SwapPassResult r = store.pass(active, camera, 4.0f, 100);
  EXPECT_EQ(r.swapped_out + r.swapped_in + r.merged, 0);
  EXPECT_EQ(active.keys, map.keys);
  EXPECT_TRUE(store.empty());
  r = store.pass(active, camera, 1.0f, 100);
  // Centres 0.04 + 0.4 i: within 1 m of the camera for i = 0, 1, 2.
  EXPECT_EQ(r.swapped_out, 7);
  EXPECT_EQ(r.swapped_in, 0);
  EXPECT_EQ(active.keys.size(), 3u);
  EXPECT_EQ(store.block_count(), 7);
  for (uint64_t key : active.keys) EXPECT_LE(distance(key, camera), 1.0f);
  // Nothing is lost: the union is the map, bit for bit.
  const BlockMapContents whole = store.with_store(active);
  EXPECT_EQ(whole.keys, map.keys);
  EXPECT_EQ(std::memcmp(whole.voxels.data(), map.voxels.data(), map.voxels.size() * sizeof(Voxel)),
            0);

  // The camera moves to the far end: the near blocks leave, the far ones come back, but only
  // as many as fit (2 of the 3 within 1 m), nearest first.
  const Vec3f far_camera{3.64f, 0.04f, 0.04f};
  r = store.pass(active, far_camera, 1.0f, 2);
  EXPECT_EQ(r.swapped_out, 3);
  EXPECT_EQ(r.swapped_in, 2);
  ASSERT_EQ(active.keys.size(), 2u);
  for (uint64_t key : active.keys) EXPECT_LE(distance(key, far_camera), 0.41f);
  EXPECT_EQ(store.block_count(), 8);
  EXPECT_EQ(store.with_store(active).keys, map.keys);
}

TEST(BlockSwap, BlockAllocatedAgainMergesWithItsStoredCopy) {
  BlockSwapStore store;
  BlockMapContents active = blocks_at({pack_block_key(100, 0, 0)});
  store.pass(active, Vec3f{0, 0, 0}, 1.0f, 10);  // 8 m away: stored
  ASSERT_TRUE(active.keys.empty());
  // The band reaches it again before a pass brings it back: a fresh copy with other
  // measurements (tsdf 300, weight 1 each).
  BlockMapContents fresh = blocks_at({pack_block_key(100, 0, 0)});
  for (Voxel& v : fresh.voxels) v = Voxel{300, 1};
  const BlockMapContents whole = store.with_store(fresh);
  ASSERT_EQ(whole.keys.size(), 1u);
  EXPECT_EQ(whole.voxels[0].weight, 2);
  EXPECT_EQ(whole.voxels[0].tsdf, 150);  // (0·1 + 300·1) / 2
  // A pass near it brings the stored copy back, merged.
  const SwapPassResult r = store.pass(fresh, Vec3f{8.0f, 0, 0}, 1.0f, 10);
  EXPECT_EQ(r.swapped_in, 1);
  EXPECT_EQ(r.merged, 1);
  EXPECT_TRUE(store.empty());
  ASSERT_EQ(fresh.keys.size(), 1u);
  EXPECT_EQ(fresh.voxels[0].tsdf, 150);
}

struct HouseRun {
  std::vector<Mat4f> poses;
  Mesh mesh;
  BlockMapContents map;
  int most_active_blocks = 0, dropped = 0, passes = 0, swapped = 0;
};

/// 500 frames of the house at 160×120 with the camera three times as fast, tracked at full
/// size with the raycast's far plane and the depth cut at 3 m, on 1 cm blocks.
HouseRun run_house(const std::vector<std::pair<std::string, std::string>>& settings,
                   BackendKind backend) {
  auto reader =
      io::make_synthetic_reader("synthetic:scene=house,frames=500,width=160,height=120,speed=3");
  PipelineConfig config;
  for (const auto& [key, value] : reader->recommended_settings()) {
    set_config_value(config, key, value);
  }
  set_config_value(config, "compute_size_ratio", "1");
  set_config_value(config, "far_m", "3");
  set_config_value(config, "max_depth_m", "3");
  for (const auto& [key, value] : settings) set_config_value(config, key, value);
  Pipeline pipeline(config, reader->default_intrinsics().value(), reader->width_px(),
                    reader->height_px(), backend);
  HouseRun run;
  io::Frame frame;
  while (reader->next(frame).status == io::ReadStatus::kOk) {
    const FrameReport r = pipeline.process(frame.depth_mm);
    run.poses.push_back(r.T_world_cam);
    run.most_active_blocks = std::max(run.most_active_blocks, r.map_blocks);
    run.dropped += r.map_blocks_dropped;
    run.passes = r.map_swap_passes;
    run.swapped = r.map_blocks_swapped;
  }
  run.mesh = Mesh(pipeline.extract_mesh());
  run.map = pipeline.read_map();
  return run;
}

/// The reference keeps every block (map_swap off, the default budget). The other has a budget
/// of 75 MiB, about 37,000 blocks, short of the reference's map, and swaps beyond 4.3 m (about
/// the least this camera allows: its raycast reaches 4.03 m at the image's corners). The
/// raycast never reads a stored block, and with the depth cut at the far plane integration
/// never writes one: the trajectory, the mesh and the saved map are the same bytes.
void expect_swapping_changes_no_bytes(BackendKind backend) {
  const HouseRun whole = run_house({{"map_swap", "off"}}, backend);
  const HouseRun swapped =
      run_house({{"map_budget_mb", "75"}, {"map_swap_distance_m", "4.3"}}, backend);
  EXPECT_EQ(whole.dropped, 0);
  EXPECT_EQ(swapped.dropped, 0);
  EXPECT_EQ(whole.passes, 0);
  EXPECT_GT(swapped.passes, 5);
  EXPECT_GT(swapped.swapped, 5000);
  const uint32_t capacity = block_capacity_for_budget(uint64_t{75} << 20);
  EXPECT_GT(whole.map.keys.size(), capacity);  // the whole map would not fit the budget
  EXPECT_LE(static_cast<uint32_t>(swapped.most_active_blocks), capacity);

  ASSERT_EQ(whole.poses.size(), swapped.poses.size());
  EXPECT_EQ(
      std::memcmp(whole.poses.data(), swapped.poses.data(), whole.poses.size() * sizeof(Mat4f)), 0);
  EXPECT_EQ(whole.map.keys, swapped.map.keys);
  ASSERT_EQ(whole.map.voxels.size(), swapped.map.voxels.size());
  EXPECT_EQ(std::memcmp(whole.map.voxels.data(), swapped.map.voxels.data(),
                        whole.map.voxels.size() * sizeof(Voxel)),
            0);
  ASSERT_EQ(whole.mesh.vertices.size(), swapped.mesh.vertices.size());
  ASSERT_EQ(whole.mesh.triangles.size(), swapped.mesh.triangles.size());
  EXPECT_EQ(std::memcmp(whole.mesh.vertices.data(), swapped.mesh.vertices.data(),
                        whole.mesh.vertices.size() * sizeof(MeshVertex)),
            0);
  EXPECT_EQ(std::memcmp(whole.mesh.triangles.data(), swapped.mesh.triangles.data(),
                        whole.mesh.triangles.size() * sizeof(MeshTriangle)),
            0);
}

TEST(BlockSwap, HouseRunThatSwapsGivesTheBytesOfOneThatNeverDoes) {
  expect_swapping_changes_no_bytes(BackendKind::kCpu);
}

TEST(BlockSwap, HouseRunThatSwapsGivesTheBytesOfOneThatNeverDoesOnCuda) {
  std::string why_not;
  if (!cuda_available(&why_not)) GTEST_SKIP() << why_not;
  expect_swapping_changes_no_bytes(BackendKind::kCuda);
}

TEST(BlockSwap, SwapDistanceShorterThanTheRaycastsReachIsRefused) {
  auto reader = io::make_synthetic_reader("synthetic:scene=house,frames=1,width=160,height=120");
  PipelineConfig config;
  for (const auto& [key, value] : reader->recommended_settings()) {
    set_config_value(config, key, value);
  }
  set_config_value(config, "map_swap_distance_m", "4");
  try {
    Pipeline pipeline(config, reader->default_intrinsics().value(), reader->width_px(),
                      reader->height_px(), BackendKind::kCpu);
    FAIL() << "a swap distance inside the raycast's reach was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("map_swap_distance_m 4 m is too short"), std::string::npos)
        << e.what();
  }
  // Swapping off, the distance is not used.
  set_config_value(config, "map_swap", "off");
  EXPECT_NO_THROW(Pipeline(config, reader->default_intrinsics().value(), reader->width_px(),
                           reader->height_px(), BackendKind::kCpu));
}

}  // namespace
}  // namespace kfx
