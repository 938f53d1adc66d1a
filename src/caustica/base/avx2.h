// What the CPU's AVX2 code (the lane driver, integrator/path_lanes.cpp; the small-scene accelerator,
// backend/cpu/small_accel.cpp) needs around it: whether this build can have it, whether this CPU runs it,
// and the markers that compile the code between them for AVX2 while the rest of the file (and every
// header included before the first marker) keeps the baseline x86-64 instruction set.
#pragma once

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(__CUDACC__)
#define CAUSTICA_AVX2_BUILD 1
#else
#define CAUSTICA_AVX2_BUILD 0
#endif

#if CAUSTICA_AVX2_BUILD
namespace caustica {
// Whether this CPU runs AVX2 (checked at run time: the build targets any x86-64).
inline bool cpu_has_avx2() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
}
}  // namespace caustica

#if defined(__clang__)
#define CAUSTICA_AVX2_BEGIN _Pragma("clang attribute push(__attribute__((target(\"avx2\"))), apply_to = function)")
#define CAUSTICA_AVX2_END _Pragma("clang attribute pop")
#else
#define CAUSTICA_AVX2_BEGIN _Pragma("GCC push_options") _Pragma("GCC target(\"avx2\")")
#define CAUSTICA_AVX2_END _Pragma("GCC pop_options")
#endif
#endif
