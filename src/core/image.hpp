#pragma once
/// Non-owning 2-D image views (host or device memory) and an owning host image.

#include <cstdint>
#include <type_traits>
#include <vector>

#include "core/platform.hpp"

namespace kfx {

/// A pixel value read by ImageView::read_early(): on the GPU the value, read when the
/// PixelRead was made; on the host the pixel's address, read by value().
template <class T>
struct PixelRead {
#if defined(__CUDA_ARCH__)
  T pixel;
  KFX_HD const T& value() const { return pixel; }
#else
  const T* pixel;
  const T& value() const { return *pixel; }
#endif
};

/// A row-major image view of `width × height` elements; `pitch` elements between rows.
template <class T>
struct ImageView {
  T* data = nullptr;
  int width = 0;
  int height = 0;
  int pitch = 0;

  KFX_HD T& operator()(int x, int y) const { return data[x + y * pitch]; }
  /// Pixel (x, y) by value, on the GPU through the read-only data cache (ld.global.nc), and
  /// loaded where the call stands (a volatile load the compiler does not move into a later
  /// branch): a kernel can issue several independent reads before the first test that needs
  /// one. Faster where a kernel reads the same pixels again and again (the persistent ICP,
  /// bench/RESULTS.md). Only for pixels that no thread writes while the kernel runs. T is made of
  /// 4-byte words (float, Vec3f, ...).
  KFX_HD std::remove_const_t<T> read_only(int x, int y) const {
#if defined(__CUDA_ARCH__)
    using Value = std::remove_const_t<T>;
    static_assert(sizeof(Value) % sizeof(float) == 0, "read_only reads 4-byte words");
    Value value;
    const float* from = reinterpret_cast<const float*>(&data[x + y * pitch]);
    float* to = reinterpret_cast<float*>(&value);
    for (int i = 0; i < static_cast<int>(sizeof(Value) / sizeof(float)); ++i) {
      asm volatile("ld.global.nc.f32 %0, [%1];" : "=f"(to[i]) : "l"(from + i));
    }
    return value;
#else
    return data[x + y * pitch];
#endif
  }
  /// A read of pixel (x, y) that the GPU issues here, through read_only(), and the host performs
  /// where value() is called. A kernel body can so start a read before the test that may not
  /// need it: one memory round trip fewer in a chain the GPU waits on, while the host's code,
  /// and so its float results, stay those of reading at the use.
  KFX_HD PixelRead<std::remove_const_t<T>> read_early(int x, int y) const {
#if defined(__CUDA_ARCH__)
    return {read_only(x, y)};
#else
    return {&data[x + y * pitch]};
#endif
  }
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

}  // namespace kfx
