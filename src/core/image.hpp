#pragma once
/// Non-owning 2-D image views (host or device memory) and an owning host image.

#include <algorithm>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "core/platform.hpp"

namespace kfx {

/// A row-major image view of `width × height` elements; `pitch` elements between rows.
template <class T>
struct ImageView {
  T* data = nullptr;
  int width = 0;
  int height = 0;
  int pitch = 0;

  KFX_HD T& operator()(int x, int y) const { return data[x + y * pitch]; }
  /// A read-only view of the same pixels.
  template <class U = T, class = std::enable_if_t<!std::is_const<U>::value>>
  KFX_HD operator ImageView<const U>() const {
    return ImageView<const U>{data, width, height, pitch};
  }
  KFX_HD bool contains(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }
  KFX_HD int size() const { return width * height; }
};

/// An owning, contiguous host image.
template <class T>
class HostImage {
 public:
  HostImage() = default;
  HostImage(int width, int height, T fill = T{})
      : pixels_(static_cast<size_t>(width) * height, fill), width_(width), height_(height) {}

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return pixels_.empty(); }
  T* data() { return pixels_.data(); }
  const T* data() const { return pixels_.data(); }
  T& operator()(int x, int y) {
    return pixels_[static_cast<size_t>(x) + static_cast<size_t>(y) * width_];
  }
  const T& operator()(int x, int y) const {
    return pixels_[static_cast<size_t>(x) + static_cast<size_t>(y) * width_];
  }
  /// A mutable view of the whole image.
  ImageView<T> view() { return {pixels_.data(), width_, height_, width_}; }
  /// A read-only view of the whole image.
  ImageView<const T> view() const { return {pixels_.data(), width_, height_, width_}; }
  const std::vector<T>& pixels() const { return pixels_; }
  std::vector<T>& pixels() { return pixels_; }

 private:
  std::vector<T> pixels_;
  int width_ = 0;
  int height_ = 0;
};

/// 8-bit RGBA pixel for renders.
struct Rgba8 {
  uint8_t r, g, b, a;
};

/// 8-bit RGB pixel of an input colour image (sRGB as the camera stores it).
struct Rgb8 {
  uint8_t r, g, b;
};

/// An owning copy of the pixels `view` shows (its pitch dropped).
template <class T>
HostImage<T> copy_of(ImageView<const T> view) {
  HostImage<T> out(view.width, view.height);
  for (int y = 0; y < view.height; ++y) {
    std::copy(view.data + static_cast<size_t>(y) * view.pitch,
              view.data + static_cast<size_t>(y) * view.pitch + view.width,
              out.data() + static_cast<size_t>(y) * view.width);
  }
  return out;
}

}  // namespace kfx
