/// kfx::Sequence over the readers (src/io/).

#include "kfx/sequence.hpp"

#include <algorithm>
#include <cstring>

#include "api/internal.hpp"
#include "core/platform.hpp"

namespace kfx {

struct Sequence::Impl {
  std::string input;
  std::unique_ptr<io::Reader> reader;
  io::Frame frame;  ///< the reader's buffer, reused
  std::string message;
};

bool has_openni2() { return io::openni2_built(); }

FrameView SequenceFrame::view() const {
  FrameView v;
  v.depth.data = depth_mm.data();
  v.depth.width_px = width_px;
  v.depth.height_px = height_px;
  v.depth.type = DepthType::kUint16;
  v.depth.units_per_m = 1000.0;
  if (!colour.empty()) {
    v.colour.data = colour.data();
    v.colour.width_px = width_px;
    v.colour.height_px = height_px;
  }
  v.stamp_s = stamp_s;
  v.input_index = index;
  return v;
}

namespace api {

FrameView frame_view(const io::Frame& frame) {
  FrameView v;
  v.depth.data = frame.depth_mm.data();
  v.depth.width_px = frame.depth_mm.width();
  v.depth.height_px = frame.depth_mm.height();
  if (!frame.rgb.empty()) {
    v.colour.data = reinterpret_cast<const uint8_t*>(frame.rgb.data());
    v.colour.width_px = frame.rgb.width();
    v.colour.height_px = frame.rgb.height();
  }
  v.stamp_s = frame.stamp_s;
  v.input_index = frame.index;
  return v;
}

}  // namespace api

Sequence::Sequence(const std::string& input, double depth_scale_per_m,
                   const std::string& ground_truth_path)
    : impl_(std::make_unique<Impl>()) {
  io::ReaderOptions options;
  options.depth_scale_per_m = depth_scale_per_m;
  options.ground_truth_path = ground_truth_path;
  impl_->input = input;
  impl_->reader = io::open_reader(input, options);
}

Sequence::~Sequence() = default;
Sequence::Sequence(Sequence&&) noexcept = default;
Sequence& Sequence::operator=(Sequence&&) noexcept = default;

ReadStatus Sequence::next(SequenceFrame& out) {
  const io::ReadResult result = impl_->reader->next(impl_->frame);
  impl_->message = result.message;
  if (result.status == io::ReadStatus::kEnd) return ReadStatus::kEnd;
  if (result.status == io::ReadStatus::kBadFrame) return ReadStatus::kBadFrame;
  const io::Frame& f = impl_->frame;
  out.index = f.index;
  out.stamp_s = f.stamp_s;
  out.width_px = f.depth_mm.width();
  out.height_px = f.depth_mm.height();
  out.depth_mm.assign(f.depth_mm.pixels().begin(), f.depth_mm.pixels().end());
  out.colour.clear();
  if (!f.rgb.empty()) {  // the reader's colour, r g b per pixel, the depth's size
    const auto* bytes = reinterpret_cast<const uint8_t*>(f.rgb.data());
    out.colour.assign(bytes, bytes + f.rgb.pixels().size() * sizeof(Rgb8));
  }
  out.source = f.source;
  return ReadStatus::kOk;
}

const std::string& Sequence::message() const { return impl_->message; }
const std::string& Sequence::input() const { return impl_->input; }
int Sequence::width_px() const { return impl_->reader->width_px(); }
int Sequence::height_px() const { return impl_->reader->height_px(); }
int Sequence::frame_count() const { return impl_->reader->frame_count(); }
bool Sequence::has_colour() const { return impl_->reader->has_colour(); }

std::optional<Camera> Sequence::camera() const {
  const auto k = impl_->reader->default_intrinsics();
  if (!k) return std::nullopt;
  Camera c;
  c.width_px = width_px();
  c.height_px = height_px();
  c.fx_px = k->fx;
  c.fy_px = k->fy;
  c.cx_px = k->cx;
  c.cy_px = k->cy;
  const LensDistortion d = impl_->reader->default_distortion();
  c.distortion = {d.k1, d.k2, d.p1, d.p2, d.k3};
  return c;
}

std::string Sequence::camera_source() const { return impl_->reader->intrinsics_source(); }

std::vector<StampedPose> Sequence::ground_truth() const {
  std::vector<StampedPose> poses;
  for (const io::StampedPose& p : impl_->reader->ground_truth()) {
    StampedPose q;
    q.stamp_s = p.stamp_s;
    std::copy(p.t, p.t + 3, q.t.begin());
    std::copy(p.q, p.q + 4, q.q.begin());
    poses.push_back(q);
  }
  return poses;
}

std::string Sequence::description() const { return impl_->reader->description(); }

std::vector<std::pair<std::string, std::string>> Sequence::recommended_settings() const {
  return impl_->reader->recommended_settings();
}

io::Reader& SequenceAccess::reader(Sequence& sequence) { return *sequence.impl_->reader; }
const io::Reader& SequenceAccess::reader(const Sequence& sequence) {
  return *sequence.impl_->reader;
}

}  // namespace kfx
