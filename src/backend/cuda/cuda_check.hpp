#pragma once
/// Error checks for every CUDA runtime call and kernel launch.

#include <cuda_runtime.h>

#include "core/platform.hpp"

namespace kfx::cuda {

/// What an error means for the run: errors that leave the context unusable (a lost or faulted
/// device) are said plainly, since every later call fails too.
inline const char* cuda_error_consequence(cudaError_t status) {
  switch (status) {
    case cudaErrorIllegalAddress:
    case cudaErrorLaunchFailure:
    case cudaErrorHardwareStackError:
    case cudaErrorIllegalInstruction:
    case cudaErrorMisalignedAddress:
    case cudaErrorInvalidPc:
    case cudaErrorECCUncorrectable:
      return "; the GPU context is lost (a kernel faulted or the device failed): the run cannot "
             "continue";
    case cudaErrorDevicesUnavailable:
    case cudaErrorNoDevice:
    case cudaErrorInitializationError:
    case cudaErrorSystemNotReady:
      return "; no usable GPU (lost, busy or not initialised)";
    case cudaErrorMemoryAllocation:
      return "; out of GPU memory";
    default:
      return "";
  }
}

}  // namespace kfx::cuda

/// Throws kfx::Error naming the call and CUDA's error (and what it means for the run) when
/// `call` fails.
#define KFX_CUDA_CHECK(call)                                                           \
  do {                                                                                 \
    const cudaError_t kfx_cuda_status_ = (call);                                       \
    KFX_CHECK(kfx_cuda_status_ == cudaSuccess,                                         \
              "CUDA error " << cudaGetErrorName(kfx_cuda_status_) << " ("              \
                            << cudaGetErrorString(kfx_cuda_status_) << ") in " #call   \
                            << ::kfx::cuda::cuda_error_consequence(kfx_cuda_status_)); \
  } while (0)

/// Checks the last launch (configuration errors; asynchronous faults surface at the next sync).
#define KFX_CUDA_LAUNCH_CHECK() KFX_CUDA_CHECK(cudaGetLastError())
