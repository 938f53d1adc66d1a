// Random numbers: PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast
// Space-Efficient Statistically Good Algorithms for Random Number Generation",
// the XSH-RR output function on a 64-bit LCG) and integer hashes used to seed
// one independent stream per (pixel, sample index) or per (pass, photon index).
#pragma once
#include <cstdint>
#include <cstring>
#include "host_device.h"
#include "math.h"

namespace caustica {

// 64-bit finaliser of MurmurHash3 (a bijection with full avalanche). Written once for any type with
// uint64_t's operators (uint64_t, and the CPU's eight-lane vectors in base/lanes.h).
template <typename U64>
CHD U64 mix64_of(U64 k) {
  k ^= k >> 33; k *= 0xff51afd7ed558ccdULL;
  k ^= k >> 33; k *= 0xc4ceb9fe1a85ec53ULL;
  k ^= k >> 33; return k;
}
CHD uint64_t mix64(uint64_t k) { return mix64_of(k); }
CHD uint64_t hash3(uint64_t a, uint64_t b, uint64_t c) {
  return mix64(a * 0x9E3779B97F4A7C15ULL ^ mix64(b + 0x632BE59BD9B4E019ULL) ^ mix64(c ^ 0x8CB92BA72F3D8DD7ULL));
}

// The bits of a float (for hashing it).
CHD uint32_t float_bits(float f) {
#ifdef __CUDA_ARCH__
  return __float_as_uint(f);
#else
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
#endif
}

CHD float u32_to_unit_float(uint32_t v) {
  // 24 random mantissa bits: uniform in [0, 1) and never 1.
  return float(v >> 8) * 0x1p-24f;
}

struct PCG32 {
  uint64_t state = 0x853c49e6748fea9bULL;
  uint64_t inc = 0xda3e39cb94b95bdbULL;

  PCG32() = default;
  CHD PCG32(uint64_t seq_index, uint64_t seed) { set_sequence(seq_index, seed); }
  CHD void set_sequence(uint64_t seq_index, uint64_t seed) {
    state = 0u;
    inc = (seq_index << 1u) | 1u;
    next_u32();
    state += seed;
    next_u32();
  }
  CHD uint32_t next_u32() {
    uint64_t old = state;
    state = old * 0x5851f42d4c957f2dULL + inc;
    uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = uint32_t(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
  }
  CHD float next_float() { return u32_to_unit_float(next_u32()); }
};

}  // namespace caustica
