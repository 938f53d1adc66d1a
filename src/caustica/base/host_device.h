// The one macro that marks code callable on both the CPU and an NVIDIA GPU.
// Per-ray, per-photon and per-pixel code lives in headers, uses no virtual
// functions, exceptions, heap allocation or std containers, and is marked with it.
#pragma once

#if defined(__CUDACC__)
#define CAUSTICA_HOST_DEVICE __host__ __device__
#define CAUSTICA_INLINE __forceinline__
#else
#define CAUSTICA_HOST_DEVICE
#define CAUSTICA_INLINE inline
#endif

#define CHD CAUSTICA_HOST_DEVICE CAUSTICA_INLINE

// CHD, and inlined at every call site by the host compiler too (nvcc's __forceinline__ already does on both
// sides): for a large stage function called from several places in one caller, which GCC would otherwise
// keep out of line (measured: pm's two trace_camera calls per sample, 4.6% of its time).
#if defined(__CUDACC__)
#define CHD_ALWAYS_INLINE CHD
#else
#define CHD_ALWAYS_INLINE CAUSTICA_HOST_DEVICE inline __attribute__((always_inline))
#endif

// For a rarely taken branch kept out of its caller's body (so that the common path stays small and inlined).
#if defined(__CUDACC__)
#define CAUSTICA_NOINLINE __noinline__
#else
#define CAUSTICA_NOINLINE __attribute__((noinline))
#endif
