#include "eval/image_quality.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include "core/platform.hpp"

namespace kfx::eval {
namespace {

constexpr int kRadius = 5;  ///< 11×11 window
constexpr double kSigma = 1.5;

double luma(uint8_t r, uint8_t g, uint8_t b) { return 0.299 * r + 0.587 * g + 0.114 * b; }

}  // namespace

ImageQuality compare_render(const HostImage<Rgba8>& render, const HostImage<Rgb8>& reference) {
  KFX_CHECK(render.width() == reference.width() && render.height() == reference.height(),
            "render is " << render.width() << "x" << render.height() << ", reference "
                         << reference.width() << "x" << reference.height());
  const int w = render.width(), h = render.height();
  ImageQuality q;
  double sum_sq = 0;
  std::vector<double> a(static_cast<size_t>(w) * h), b(a.size());
  std::vector<uint8_t> covered(a.size());
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const Rgba8 r = render(x, y);
      const Rgb8 p = reference(x, y);
      a[i] = luma(r.r, r.g, r.b);
      b[i] = luma(p.r, p.g, p.b);
      covered[i] = r.a > 0;
      if (!covered[i]) continue;
      ++q.covered_pixels;
      const double dr = r.r - p.r, dg = r.g - p.g, db = r.b - p.b;
      sum_sq += dr * dr + dg * dg + db * db;
    }
  }
  if (q.covered_pixels == 0) return q;
  q.covered_fraction = static_cast<double>(q.covered_pixels) / (static_cast<double>(w) * h);
  const double mse = sum_sq / (3.0 * static_cast<double>(q.covered_pixels));
  q.psnr_db =
      mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : std::numeric_limits<double>::infinity();

  double kernel[2 * kRadius + 1], kernel_sum = 0;
  for (int i = -kRadius; i <= kRadius; ++i) {
    kernel[i + kRadius] = std::exp(-0.5 * i * i / (kSigma * kSigma));
    kernel_sum += kernel[i + kRadius];
  }
  const double c1 = (0.01 * 255) * (0.01 * 255), c2 = (0.03 * 255) * (0.03 * 255);
  double ssim_sum = 0;
  for (int y = kRadius; y < h - kRadius; ++y) {
    for (int x = kRadius; x < w - kRadius; ++x) {
      double ma = 0, mb = 0, aa = 0, bb = 0, ab = 0;
      bool inside = true;
      for (int j = -kRadius; j <= kRadius && inside; ++j) {
        for (int i = -kRadius; i <= kRadius; ++i) {
          const size_t k = static_cast<size_t>(y + j) * w + (x + i);
          if (!covered[k]) {
            inside = false;
            break;
          }
          const double g = kernel[j + kRadius] * kernel[i + kRadius] / (kernel_sum * kernel_sum);
          ma += g * a[k];
          mb += g * b[k];
          aa += g * a[k] * a[k];
          bb += g * b[k] * b[k];
          ab += g * a[k] * b[k];
        }
      }
      if (!inside) continue;
      const double va = aa - ma * ma, vb = bb - mb * mb, cov = ab - ma * mb;
      ssim_sum +=
          ((2 * ma * mb + c1) * (2 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
      ++q.ssim_windows;
    }
  }
  q.ssim = q.ssim_windows > 0 ? ssim_sum / static_cast<double>(q.ssim_windows) : 0.0;
  return q;
}

}  // namespace kfx::eval
