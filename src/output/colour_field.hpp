#pragma once
/// The model's colour field on the host, whichever map holds it (the dense cube's colour volume
/// or a block map's colours): what colours mesh vertices and cloud points.

#include <memory>
#include <vector>

#include "core/colour_volume.hpp"
#include "map/host_block_map.hpp"

namespace kfx {
class Pipeline;
}

namespace kfx::output {

/// A colour field to sample at points of the map frame; empty when the model has no colour.
class ColourField {
 public:
  /// No colour.
  ColourField() = default;
  /// The dense cube's colour field `view` (not owned: it must outlive this object); empty when
  /// the view has no data.
  ColourField(const ColourVolumeView& view);  // NOLINT: a view is a field
  /// The dense cube's colour voxels (res³, x fastest) over a cube of size_m metres.
  ColourField(std::vector<ColourVoxel> voxels, int res, float size_m);
  /// A block map's colours (contents.colours; empty when the map has none). The field keeps
  /// `contents` and samples its arrays in place.
  explicit ColourField(BlockMapContents contents);

  /// True when there is no colour to sample.
  bool empty() const { return !dense_.data && !blocks_; }
  /// The colour at map-frame point p_m (sample_colour's rule); false where none was fused.
  bool sample(Vec3f p_m, Vec3f& rgb) const;

 private:
  std::vector<ColourVoxel> dense_voxels_;  ///< owned dense voxels, when constructed from them
  ColourVolumeView dense_;
  /// A block map's contents and their index (HostBlockMap::view_of_contents), when built from one.
  struct Blocks {
    Blocks() = default;
    Blocks(const Blocks&) = delete;  // `view` points into this object's own arrays
    Blocks& operator=(const Blocks&) = delete;
    BlockMapContents contents;
    HostBlockMap index;
    BlockMapView view;
  };
  std::shared_ptr<Blocks> blocks_;
};

/// The colour field of `pipeline`'s model, read from its backend; empty when colour is off.
ColourField read_colour_field(Pipeline& pipeline);

}  // namespace kfx::output
