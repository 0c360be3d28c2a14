#pragma once
/// Where a map's memory lives. A map's storage (map/block_map_store.hpp, map/dense_cube.hpp) is
/// written once, as a template on a memory policy: the policy names its buffer type and the few
/// operations on whole buffers the storage needs (fill). HostMemory is here; the CUDA backend
/// has DeviceMemory (backend/cuda/cuda_map_memory.cuh), with the same members, over device
/// buffers and its stream. What reads and writes single elements is not the policy's: the
/// kernel bodies do it through the maps' views (KFX_HD), on either side.

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <memory>

namespace kfx {

/// Where a map lives.
enum class MemoryLocation : int {
  kHost = 0,    ///< host memory: the CPU backend's map, and maps read back or loaded from a file
  kDevice = 1,  ///< GPU memory: the CUDA backend's map
};

/// An owning array of host memory whose elements start uninitialised: a map sized from a
/// large budget costs address space, not memory, until its blocks are used.
template <class T>
class HostBuffer {
 public:
  HostBuffer() = default;
  explicit HostBuffer(size_t count) : data_(count > 0 ? new T[count] : nullptr), count_(count) {}
  T* data() const { return data_.get(); }
  size_t size() const { return count_; }
  size_t bytes() const { return count_ * sizeof(T); }

 private:
  std::unique_ptr<T[]> data_;
  size_t count_ = 0;
};

/// The host memory policy.
struct HostMemory {
  static constexpr MemoryLocation kLocation = MemoryLocation::kHost;
  template <class T>
  using Buffer = HostBuffer<T>;
  /// Every byte of `buffer` set to `byte`.
  template <class T>
  void fill_bytes(const Buffer<T>& buffer, int byte) const {
    if (buffer.size() > 0) std::memset(static_cast<void*>(buffer.data()), byte, buffer.bytes());
  }
  /// Every element of `buffer` set to `value`.
  template <class T>
  void fill(const Buffer<T>& buffer, const T& value) const {
    std::fill_n(buffer.data(), buffer.size(), value);
  }
};

}  // namespace kfx
