#pragma once
/// RAII owners of device memory, pinned host memory, streams, events and graphs. Everything is
/// allocated once, at construction; destructors never throw.

#include <cuda_runtime.h>

#include <cstddef>
#include <sstream>
#include <utility>

#include "backend/cuda/cuda_check.hpp"
#include "core/image.hpp"

namespace kfx::cuda {

/// Throws kfx::Error for a failed allocation of `bytes` ("device" or "pinned host" memory),
/// with the size and what the GPU has free. The stage is the backend's construction, as
/// every buffer is allocated once there.
inline void fail_allocation(cudaError_t status, size_t bytes, const char* kind) {
  cudaGetLastError();  // clear the error so the query below can succeed
  constexpr double kMiB = 1024.0 * 1024.0;
  std::ostringstream gpu;
  size_t free_bytes = 0, total_bytes = 0;
  if (cudaMemGetInfo(&free_bytes, &total_bytes) == cudaSuccess) {
    gpu << "; the GPU has " << free_bytes / kMiB << " MiB free of " << total_bytes / kMiB << " MiB";
  }
  KFX_FAIL("CUDA backend setup: cannot allocate "
           << bytes / kMiB << " MiB of " << kind << " memory: " << cudaGetErrorName(status) << " ("
           << cudaGetErrorString(status) << ")" << gpu.str());
}

/// `count` elements of T in device memory.
template <class T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(size_t count) : count_(count) {
    if (count == 0) return;
    const cudaError_t status = cudaMalloc(&data_, count * sizeof(T));
    if (status != cudaSuccess) fail_allocation(status, count * sizeof(T), "device");
  }
  ~DeviceBuffer() {
    if (data_) cudaFree(data_);
  }
  DeviceBuffer(DeviceBuffer&& other) noexcept { *this = std::move(other); }
  DeviceBuffer& operator=(DeviceBuffer&& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(count_, other.count_);
    return *this;
  }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;

  T* data() const { return data_; }
  size_t size() const { return count_; }
  size_t bytes() const { return count_ * sizeof(T); }

 private:
  T* data_ = nullptr;
  size_t count_ = 0;
};

/// A width × height image of T in device memory (row-major, no padding).
template <class T>
class DeviceImage {
 public:
  DeviceImage() = default;
  DeviceImage(int width, int height)
      : buffer_(static_cast<size_t>(width) * height), width_(width), height_(height) {}
  int width() const { return width_; }
  int height() const { return height_; }
  T* data() const { return buffer_.data(); }
  size_t bytes() const { return buffer_.bytes(); }
  ImageView<T> view() const { return {buffer_.data(), width_, height_, width_}; }

 private:
  DeviceBuffer<T> buffer_;
  int width_ = 0;
  int height_ = 0;
};

/// `count` elements of T in page-locked host memory (fast, asynchronous copies).
template <class T>
class PinnedBuffer {
 public:
  PinnedBuffer() = default;
  explicit PinnedBuffer(size_t count) : count_(count) {
    if (count == 0) return;
    const cudaError_t status = cudaMallocHost(&data_, count * sizeof(T));
    if (status != cudaSuccess) fail_allocation(status, count * sizeof(T), "pinned host");
  }
  ~PinnedBuffer() {
    if (data_) cudaFreeHost(data_);
  }
  PinnedBuffer(PinnedBuffer&& other) noexcept { *this = std::move(other); }
  PinnedBuffer& operator=(PinnedBuffer&& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(count_, other.count_);
    return *this;
  }
  PinnedBuffer(const PinnedBuffer&) = delete;
  PinnedBuffer& operator=(const PinnedBuffer&) = delete;

  T* data() const { return data_; }
  size_t size() const { return count_; }

 private:
  T* data_ = nullptr;
  size_t count_ = 0;
};

/// A non-blocking stream (never the legacy default stream).
class Stream {
 public:
  Stream() { KFX_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking)); }
  ~Stream() { cudaStreamDestroy(stream_); }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  cudaStream_t get() const { return stream_; }

 private:
  cudaStream_t stream_ = nullptr;
};

/// A CUDA event (timing enabled unless `timing` is false).
class Event {
 public:
  explicit Event(bool timing = true) {
    KFX_CUDA_CHECK(
        cudaEventCreateWithFlags(&event_, timing ? cudaEventDefault : cudaEventDisableTiming));
  }
  ~Event() { cudaEventDestroy(event_); }
  Event(const Event&) = delete;
  Event& operator=(const Event&) = delete;
  cudaEvent_t get() const { return event_; }

 private:
  cudaEvent_t event_ = nullptr;
};

/// An instantiated, replayable CUDA graph.
class GraphExec {
 public:
  GraphExec() = default;
  /// Instantiates `graph` (and destroys the template graph).
  explicit GraphExec(cudaGraph_t graph) {
    const cudaError_t status = cudaGraphInstantiate(&exec_, graph, 0);
    cudaGraphDestroy(graph);
    KFX_CUDA_CHECK(status);
  }
  ~GraphExec() {
    if (exec_) cudaGraphExecDestroy(exec_);
  }
  GraphExec(GraphExec&& other) noexcept { std::swap(exec_, other.exec_); }
  GraphExec& operator=(GraphExec&& other) noexcept {
    std::swap(exec_, other.exec_);
    return *this;
  }
  GraphExec(const GraphExec&) = delete;
  GraphExec& operator=(const GraphExec&) = delete;
  /// Replays the graph on `stream`.
  void launch(cudaStream_t stream) const { KFX_CUDA_CHECK(cudaGraphLaunch(exec_, stream)); }

 private:
  cudaGraphExec_t exec_ = nullptr;
};

}  // namespace kfx::cuda
