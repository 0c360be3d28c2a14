#pragma once
/// Error checks for every CUDA runtime call and kernel launch.

#include <cuda_runtime.h>

#include "core/platform.hpp"

/// Throws kfx::Error naming the call and CUDA's error when `call` fails.
#define KFX_CUDA_CHECK(call)                                                         \
  do {                                                                               \
    const cudaError_t kfx_cuda_status_ = (call);                                     \
    KFX_CHECK(kfx_cuda_status_ == cudaSuccess,                                       \
              "CUDA error " << cudaGetErrorName(kfx_cuda_status_) << " ("           \
                            << cudaGetErrorString(kfx_cuda_status_) << ") in " #call); \
  } while (0)

/// Checks the last launch (configuration errors; asynchronous faults surface at the next sync).
#define KFX_CUDA_LAUNCH_CHECK() KFX_CUDA_CHECK(cudaGetLastError())
