#pragma once
/// Memory a backend will allocate, checked against what the host or GPU has before allocating,
/// so `-v 1024` on a small machine says what it needs instead of `std::bad_alloc`.

#include <cstdint>
#include <string>

#include "backend/backend.hpp"

namespace kfx {

/// Bytes a backend allocates for `setup`: the volume (resolution³ voxels) plus every per-pixel
/// map and the pyramid (counted per pixel, slightly generously).
uint64_t backend_bytes_needed(const BackendSetup& setup);

/// Bytes a backend allocates for colour (BackendSetup::colour): the colour field (8 bytes per
/// voxel), the colour input buffers and the colour render; 0 with colour off.
uint64_t colour_bytes(const BackendSetup& setup);

/// Bytes one map of `setup` holds: the res³ cube, or BackendSetup::block_capacity blocks with
/// their hash, the GPU's per-frame allocation buffers and its tables; with colour, its colours.
/// The backend's first map costs this, and so does every Backend::create_map().
uint64_t map_bytes(const BackendSetup& setup);

/// Throws kfx::Error when another map (map_bytes) exceeds `available_bytes` (0 = unknown: no
/// check); the message names the maps held already (`maps_held`) and `where`.
void check_another_map_fits(const BackendSetup& setup, int maps_held, uint64_t available_bytes,
                            const std::string& where);

/// Bytes the host can still allocate without swapping (MemAvailable in /proc/meminfo); 0 when
/// unknown.
uint64_t host_bytes_available();

/// Throws kfx::Error when `needed_bytes` exceeds `available_bytes` (0 = unknown: no check). The
/// message gives both in GiB, the volume's share, and names `where` ("host memory (MemAvailable
/// in /proc/meminfo)", "free GPU memory").
void check_memory_fits(const BackendSetup& setup, uint64_t needed_bytes, uint64_t available_bytes,
                       const std::string& where);

}  // namespace kfx
