/// Any input to SLAMBench `.raw` plus sidecar.

#include "io/convert.hpp"

#include "core/platform.hpp"
#include "io/slambench_raw.hpp"

namespace kfx::io {
namespace {

/// Frames between two progress lines.
constexpr int kProgressEvery = 100;

}  // namespace

HostImage<uint16_t> subsample_nearest(const HostImage<uint16_t>& image, int ratio) {
  KFX_CHECK(ratio >= 1, "subsampling ratio must be >= 1, got " << ratio);
  if (ratio == 1) return image;
  HostImage<uint16_t> out(image.width() / ratio, image.height() / ratio);
  for (int y = 0; y < out.height(); ++y) {
    for (int x = 0; x < out.width(); ++x) out(x, y) = image(x * ratio, y * ratio);
  }
  return out;
}

HostImage<Rgb8> subsample_mean(const HostImage<Rgb8>& image, int ratio) {
  KFX_CHECK(ratio >= 1, "subsampling ratio must be >= 1, got " << ratio);
  if (ratio == 1) return image;
  HostImage<Rgb8> out(image.width() / ratio, image.height() / ratio);
  const int n = ratio * ratio;
  for (int y = 0; y < out.height(); ++y) {
    for (int x = 0; x < out.width(); ++x) {
      int r = 0, g = 0, b = 0;
      for (int j = 0; j < ratio; ++j) {
        for (int i = 0; i < ratio; ++i) {
          const Rgb8 c = image(x * ratio + i, y * ratio + j);
          r += c.r;
          g += c.g;
          b += c.b;
        }
      }
      out(x, y) = Rgb8{static_cast<uint8_t>((r + n / 2) / n), static_cast<uint8_t>((g + n / 2) / n),
                       static_cast<uint8_t>((b + n / 2) / n)};
    }
  }
  return out;
}

ConvertSummary convert_to_raw(Reader& reader, const std::string& raw_path,
                              const ConvertOptions& options) {
  const int ratio = options.ratio;
  KFX_CHECK(ratio == 1 || ratio == 2 || ratio == 4 || ratio == 8,
            "conversion ratio must be 1, 2, 4 or 8, got " << ratio);
  KFX_CHECK(options.max_frames >= 0, "frame limit must be >= 0, got " << options.max_frames);
  KFX_CHECK(reader.width_px() / ratio > 0 && reader.height_px() / ratio > 0,
            "cannot subsample " << reader.width_px() << "x" << reader.height_px() << " images by "
                                << ratio);
  const int total = options.max_frames > 0 &&
                            (reader.frame_count() < 0 || reader.frame_count() > options.max_frames)
                        ? options.max_frames
                        : reader.frame_count();
  const bool colour = options.colour && reader.has_colour();
  RawWriter writer(raw_path);
  RawSidecar sidecar;
  Frame frame;
  while (options.max_frames == 0 || writer.frames_written() < options.max_frames) {
    const ReadResult result = reader.next(frame);
    if (result.status == ReadStatus::kEnd) break;
    KFX_CHECK(result.status == ReadStatus::kOk,
              "conversion to '" << raw_path << "' stopped: " << result.message);
    if (colour) {
      const HostImage<Rgb8> rgb = subsample_mean(frame.rgb, ratio);
      writer.write_frame(subsample_nearest(frame.depth_mm, ratio), &rgb);
    } else {
      writer.write_frame(subsample_nearest(frame.depth_mm, ratio));
    }
    sidecar.stamps_s.push_back(frame.stamp_s);
    if (options.progress != nullptr && writer.frames_written() % kProgressEvery == 0) {
      *options.progress << "kfx convert: " << writer.frames_written() << "/"
                        << (total >= 0 ? std::to_string(total) : std::string("?")) << " frames\n";
    }
  }
  KFX_CHECK(writer.frames_written() > 0,
            "conversion to '" << raw_path << "' stopped: the input has no frames");
  if (const auto intrinsics = reader.default_intrinsics()) {
    sidecar.intrinsics = intrinsics->scaled_down(static_cast<float>(ratio));
    sidecar.distortion = reader.default_distortion();  // the same lens at any image size
    sidecar.ideal_lens = reader.ideal_lens();
  }
  sidecar.ground_truth = reader.ground_truth();
  sidecar.has_colour = colour;
  sidecar.recommended_settings = reader.recommended_settings();
  sidecar.source = reader.description();
  if (ratio != 1) sidecar.source += ", subsampled by " + std::to_string(ratio);
  // Sidecar first: the .raw appears last, so a finished-looking .raw always has its sidecar.
  write_raw_sidecar(raw_path, sidecar);
  writer.close();

  ConvertSummary summary;
  summary.frames = writer.frames_written();
  summary.width_px = reader.width_px() / ratio;
  summary.height_px = reader.height_px() / ratio;
  summary.has_intrinsics = sidecar.intrinsics.has_value();
  summary.ground_truth_poses = static_cast<int>(sidecar.ground_truth.size());
  summary.raw_path = raw_path;
  summary.sidecar_path = raw_sidecar_path(raw_path);
  return summary;
}

}  // namespace kfx::io
