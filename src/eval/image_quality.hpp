#pragma once
/// How closely a rendered colour image matches a photograph: PSNR and SSIM (Wang et al. 2004)
/// over the pixels the render covers, for the held-out-frame colour evaluation.

#include "core/image.hpp"

namespace kfx::eval {

/// PSNR and SSIM of a render against a reference image of the same size.
struct ImageQuality {
  double psnr_db = 0;           ///< 10·log10(255² / MSE) over covered pixels and RGB channels
  double ssim = 0;              ///< mean SSIM of the luma over covered 11×11 windows
  double covered_fraction = 0;  ///< covered pixels / all pixels
  long long covered_pixels = 0;
  long long ssim_windows = 0;  ///< windows entirely inside the covered pixels
};

/// Compares `render` (alpha 0 marks pixels it does not cover: no surface or no colour) with
/// `reference`. SSIM: Gaussian 11×11 window (σ 1.5) on luma Y = 0.299 R + 0.587 G + 0.114 B,
/// C1 = (0.01·255)², C2 = (0.03·255)², averaged over windows whose every pixel is covered.
/// Throws kfx::Error when the sizes differ. PSNR is +inf for identical covered pixels; both are
/// 0 when nothing is covered.
ImageQuality compare_render(const HostImage<Rgba8>& render, const HostImage<Rgb8>& reference);

}  // namespace kfx::eval
