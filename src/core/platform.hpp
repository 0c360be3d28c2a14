#pragma once
/// Platform glue shared by host and device code: the KFX_HD qualifier, the one error type and
/// the contract check macro. Compiles with a plain host compiler (no CUDA headers needed).

#include <sstream>
#include <string>

#if defined(__CUDACC__)
#define KFX_HD __host__ __device__
#define KFX_INLINE __forceinline__
/// Unroll the next loop completely on the GPU: small fixed-size arrays then stay in registers
/// instead of the (slow) per-thread stack. Host compilers decide for themselves.
#define KFX_UNROLL _Pragma("unroll")
/// Keep a rarely taken function out of line on the GPU, so its stack arrays and registers do
/// not weigh on the hot caller.
#define KFX_NOINLINE __noinline__
#else
#define KFX_HD
#define KFX_INLINE inline
#define KFX_UNROLL
#define KFX_NOINLINE
#endif

/// Keep a function out of line on the host and on the GPU: for a variant that, inlined, would
/// change how GCC contracts the common path's arithmetic into FMAs (and so its last bits).
#if defined(__CUDACC__)
#define KFX_OUT_OF_LINE __noinline__
#elif defined(__GNUC__)
#define KFX_OUT_OF_LINE __attribute__((noinline))
#else
#define KFX_OUT_OF_LINE
#endif

// kfx::Error, the one exception type, is public (the API throws it).
#include "kfx/error.hpp"

/// Throws kfx::Error with a streamed message when `cond` is false. Host code only.
#define KFX_CHECK(cond, msg)                                           \
  do {                                                                 \
    if (!(cond)) {                                                     \
      std::ostringstream kfx_check_stream_;                            \
      kfx_check_stream_ << msg;                                        \
      throw ::kfx::Error(kfx_check_stream_.str(), __FILE__, __LINE__); \
    }                                                                  \
  } while (0)

/// Throws kfx::Error with a streamed message unconditionally. Host code only.
#define KFX_FAIL(msg) KFX_CHECK(false, msg)
