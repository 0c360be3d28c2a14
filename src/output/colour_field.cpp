#include "output/colour_field.hpp"

#include "map/block_map.hpp"
#include "pipeline/pipeline.hpp"

namespace kfx::output {

ColourField::ColourField(const ColourVolumeView& view) : dense_(view) {}

ColourField::ColourField(std::vector<ColourVoxel> voxels, int res, float size_m)
    : dense_voxels_(std::move(voxels)),
      dense_{dense_voxels_.empty() ? nullptr : dense_voxels_.data(), res, size_m} {}

ColourField::ColourField(BlockMapContents contents) {
  if (contents.colours.empty()) return;
  blocks_ = std::make_shared<Blocks>();
  blocks_->contents = std::move(contents);
  const BlockMapContents& c = blocks_->contents;
  blocks_->index =
      HostBlockMap(static_cast<uint32_t>(c.keys.size()) + 1, c.grid_res, c.grid_size_m, true);
  blocks_->index.load_index(c);
  blocks_->view = blocks_->index.view_of_contents(c);
}

bool ColourField::sample(Vec3f p_m, Vec3f& rgb) const {
  if (dense_.data) return sample_colour(dense_, p_m, rgb);
  if (!blocks_) return false;
  return sample_colour(blocks_->view, p_m, rgb);
}

ColourField read_colour_field(Pipeline& pipeline) {
  const PipelineConfig& config = pipeline.config();
  if (!config.colour.fuse) return {};
  if (config.volume.kind == MapKind::kBlocks) return ColourField(pipeline.read_map());
  return ColourField(pipeline.backend().read_colour_volume(), config.volume.resolution_vox,
                     config.volume.size_m);
}

}  // namespace kfx::output
