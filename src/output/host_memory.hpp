#pragma once
/// Host memory: checks made before a run, so an output that cannot fit fails with the sizes
/// rather than as std::bad_alloc after the run, and the process's peak (for benchmarks).

#include <cstddef>
#include <string>

namespace kfx::output {

/// Bytes of a host copy of a res³ volume.
size_t volume_host_bytes(int res);

/// Memory the system could give now (MemAvailable of /proc/meminfo), bytes; 0 if unknown.
size_t available_host_bytes();

/// The most resident memory this process has held so far (VmHWM of /proc/self/status), bytes;
/// 0 if unknown.
size_t peak_resident_bytes();

/// Throws kfx::Error when `bytes` exceed the available host memory, giving both in GiB and
/// naming `what`. Does nothing when the available memory is unknown.
void check_host_memory(size_t bytes, const std::string& what);

}  // namespace kfx::output
