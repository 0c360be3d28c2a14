#include "output/colour_field.hpp"

#include "map/block_map.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx::output {

ColourField::ColourField(const ColourVolumeView& view) : dense_(view) {}

ColourField::ColourField(std::vector<ColourVoxel> voxels, int res, float size_m)
    : dense_voxels_(std::move(voxels)),
      dense_{dense_voxels_.empty() ? nullptr : dense_voxels_.data(), res, size_m} {}

ColourField::ColourField(const BlockMapContents& contents) {
  if (contents.colours.empty()) return;
  blocks_ = std::make_shared<HostBlockMap>(static_cast<uint32_t>(contents.keys.size()) + 1,
                                           contents.grid_res, contents.grid_size_m, true);
  blocks_->load(contents);
}

bool ColourField::sample(Vec3f p_m, Vec3f& rgb) const {
  if (dense_.data) return sample_colour(dense_, p_m, rgb);
  if (!blocks_) return false;
  // view() hands out a mutable view of the map's arrays; sampling only reads them.
  return sample_colour(const_cast<HostBlockMap&>(*blocks_).view(), p_m, rgb);
}

ColourField read_colour_field(Pipeline& pipeline) {
  const PipelineConfig& config = pipeline.config();
  if (!config.colour.fuse) return {};
  if (config.volume.kind == MapKind::kBlocks) return ColourField(pipeline.read_map());
  return ColourField(pipeline.backend().read_colour_volume(), config.volume.resolution_vox,
                     config.volume.size_m);
}

}  // namespace kfx::output
