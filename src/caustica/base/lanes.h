// Eight-lane values for the CPU's lane-parallel code (integrator/path_lanes.cpp): GCC vector
// extensions, so one expression works on eight paths at once, one AVX2 instruction per operation. x86-64
// with GCC or Clang only, and only included where `#pragma GCC target("avx2")` is in effect (the file
// that includes it checks the CPU before calling such code). CPU only: the GPU's lanes are threads.
//
// Every operation here mirrors the scalar one in math.h, rng.h and sampler.h exactly (the same IEEE
// operations in the same order: a reciprocal then products where math.h divides a vector by a scalar,
// the sign of zero kept as std::fabs and std::copysign keep it), so that a lane computes bit for bit
// what the scalar code computes for the same path. The build turns off floating-point contraction
// (-ffp-contract=off) for the same reason. tests/cpp/test_path_lanes.cpp checks it on whole images.
#pragma once
#if defined(__CUDACC__)
#error "lanes.h is CPU-only"
#endif
#include <cstdint>

#include "math.h"
#include "rng.h"
#include "sampler.h"

namespace caustica::lanes {

constexpr int kWidth = 8;
typedef float F __attribute__((vector_size(4 * kWidth)));
typedef int32_t M __attribute__((vector_size(4 * kWidth)));  // masks: all bits set (-1) or 0
typedef uint32_t U __attribute__((vector_size(4 * kWidth)));
typedef uint64_t U64 __attribute__((vector_size(8 * kWidth)));

inline F splat(float v) { return F{} + v; }
inline M none() { return M{}; }
inline M all() { return M{} - 1; }
inline F sel(M m, F a, F b) { return m ? a : b; }
inline bool any(M m) { return __builtin_ia32_movmskps256((F)m) != 0; }  // any lane's sign bit (masks: -1 or 0)
// The mask of the lanes whose bit (lane i: bit i) is set in `bits`.
inline M mask_of_bits(int bits) { return ((M{} + bits) & M{1, 2, 4, 8, 16, 32, 64, 128}) != 0; }
inline F vfabs(F a) { return (F)((U)a & 0x7fffffffu); }
// std::copysign(1.f, x), including the sign of -0.
inline F sign_of(F x) { return (F)((U)splat(1.f) | ((U)x & 0x80000000u)); }
inline F vsqrt(F x) { return __builtin_ia32_sqrtps256(x); }  // correctly rounded, as std::sqrt
// maxf / minf of math.h: a > b ? a : b, a < b ? a : b (NaN operands as there).
inline F vmaxf(F a, F b) { return sel(a > b, a, b); }
inline F vminf(F a, F b) { return sel(a < b, a, b); }
inline F safe_sqrt(F x) { return vsqrt(vmaxf(x, splat(0.f))); }
// std::isfinite: false for +-inf and NaN.
inline M finite(F x) { return vfabs(x) <= splat(0x1.fffffep127f); }

struct V3 {
  F x, y, z;
};
inline V3 splat3(Vec3f v) { return {splat(v.x), splat(v.y), splat(v.z)}; }
inline V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator-(V3 a) { return {-a.x, -a.y, -a.z}; }
inline V3 operator*(V3 a, V3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
inline V3 operator*(V3 a, F s) { return {a.x * s, a.y * s, a.z * s}; }
inline V3 operator/(V3 a, F s) {
  F r = 1.f / s;
  return {a.x * r, a.y * r, a.z * r};
}
inline F dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3 cross(V3 a, V3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline F length(V3 a) { return vsqrt(dot(a, a)); }
inline V3 normalize(V3 a) { return a / length(a); }
inline V3 vabs(V3 a) { return {vfabs(a.x), vfabs(a.y), vfabs(a.z)}; }
inline F max_component(V3 a) { return vmaxf(a.x, vmaxf(a.y, a.z)); }
inline M is_black(V3 a) { return (a.x == 0.f) & (a.y == 0.f) & (a.z == 0.f); }
inline M finite3(V3 a) { return finite(a.x) & finite(a.y) & finite(a.z); }
inline V3 sel(M m, V3 a, V3 b) { return {sel(m, a.x, b.x), sel(m, a.y, b.y), sel(m, a.z, b.z)}; }
inline void set(V3& v, int i, Vec3f s) {
  v.x[i] = s.x;
  v.y[i] = s.y;
  v.z[i] = s.z;
}
inline Vec3f get(const V3& v, int i) { return Vec3f(v.x[i], v.y[i], v.z[i]); }

// Values that a loop over the lanes writes one lane at a time and the lane code then reads as vectors:
// plain stores into arrays, one vector load each afterwards. (Writing an element of a vector variable at a
// run-time index makes GCC store and reload the whole vector around each write: about ten instructions
// per element, measured with callgrind on the path driver.)
struct Staged {
  alignas(32) float v[kWidth] = {};
  F load() const { return *reinterpret_cast<const F*>(v); }
};
struct StagedMask {
  alignas(32) int32_t v[kWidth] = {};
  M load() const { return *reinterpret_cast<const M*>(v); }
};
struct Staged3 {
  alignas(32) float x[kWidth] = {}, y[kWidth] = {}, z[kWidth] = {};
  void set(int i, Vec3f s) {
    x[i] = s.x;
    y[i] = s.y;
    z[i] = s.z;
  }
  V3 load() const {
    return {*reinterpret_cast<const F*>(x), *reinterpret_cast<const F*>(y), *reinterpret_cast<const F*>(z)};
  }
};

// Frame of math.h (Duff et al. 2017) about n.
struct Frame3 {
  V3 s, t, n;
  explicit Frame3(V3 nn) : n(nn) {
    F sign = sign_of(nn.z);
    F a = -1.f / (sign + nn.z);
    F b = nn.x * nn.y * a;
    s = {1.f + sign * nn.x * nn.x * a, sign * b, -sign * nn.x};
    t = {b, sign + nn.y * nn.y * a, -nn.y};
  }
  V3 to_local(V3 v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
  V3 to_world(V3 v) const { return s * v.x + t * v.y + n * v.z; }
};

// offset_ray_origin of geometry/ray.h.
inline V3 offset_ray_origin(V3 p, V3 ng, V3 w) {
  F scale = 1e-4f * vmaxf(splat(1.f), max_component(vabs(p)));
  V3 off = ng * scale;
  return sel(dot(w, ng) < 0.f, p - off, p + off);
}

// power_heuristic of sampling.h.
inline F power_heuristic(F pdf_a, F pdf_b) {
  F a = pdf_a * pdf_a, b = pdf_b * pdf_b;
  return sel(a == splat(kInf), splat(1.f), sel(a > 0.f, a / (a + b), splat(0.f)));
}

// square_to_concentric_disk and square_to_cosine_hemisphere of sampling.h.
inline V3 square_to_cosine_hemisphere(F ux, F uy) {
  F ox = 2.f * ux - 1.f, oy = 2.f * uy - 1.f;
  M wide = vfabs(ox) > vfabs(oy);
  F num = sel(wide, oy, ox), den = sel(wide, ox, oy);
  F s, c;
  sincos_quarter_pi_of((kPi / 4.f) * (num / den), s, c);
  F dx = sel(wide, ox * c, oy * s), dy = sel(wide, ox * s, oy * c);
  M centre = (ox == 0.f) & (oy == 0.f);
  dx = sel(centre, splat(0.f), dx);
  dy = sel(centre, splat(0.f), dy);
  return {dx, dy, safe_sqrt(1.f - dx * dx - dy * dy)};
}

// Sampler::next_2d of sampler.h (kSobol) for eight pixels at one sample index, each lane at its own
// dimension. The lane driver moves a lane's state to and from a scalar Sampler (load_lane, store_lane:
// a path's start and a vertex that the scalar stages shade), and keeps the state that a scalar vertex
// left in lanes that did not draw in lanes (Saved, keep).
struct SobolLanes {
  void load_lane(int i, const Sampler& s) {
    pixel_seed[i] = s.pixel_seed;
    dimension[i] = s.dimension;
  }
  void store_lane(int i, Sampler& s) const {
    s.type = SamplerType::kSobol;
    s.index_reversed = index_reversed;
    s.dimension = dimension[i];
    s.pixel_seed = pixel_seed[i];
  }
  void after_scalar_vertex(int i, const Sampler& s) { dimension[i] = s.dimension; }
  typedef U Saved;
  Saved save() const { return dimension; }
  // Lanes outside `drew` get back the state saved before the lanes' draws.
  void keep(M drew, Saved before) { dimension = drew ? dimension : before; }
  void init(uint32_t sample_index) {
    pixel_seed = U64{};
    dimension = U{};
    index_reversed = reverse_bits32(sample_index);
  }

  U64 pixel_seed;
  uint32_t index_reversed = 0;
  U dimension;

  static U reverse_bits(U v) {
    v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
    v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
    v = ((v >> 4) & 0x0F0F0F0Fu) | ((v & 0x0F0F0F0Fu) << 4);
    v = ((v >> 8) & 0x00FF00FFu) | ((v & 0x00FF00FFu) << 8);
    return (v >> 16) | (v << 16);
  }
  static F to_unit(U v) { return __builtin_convertvector(v >> 8, F) * 0x1p-24f; }

  void next_2d(F& x, F& y) {
    U64 h = mix64_of(pixel_seed + __builtin_convertvector(dimension, U64));
    dimension += 1u;
    U lo = __builtin_convertvector(h, U), hi = __builtin_convertvector(h >> 32, U);
    U h2 = __builtin_convertvector(mix64_of(h), U);
    U shuffled = reverse_bits(lk_permutation_of(U{} + index_reversed, lo));
    x = to_unit(reverse_bits(lk_permutation_of(shuffled, hi)));
    y = to_unit(reverse_bits(lk_permutation_of(sobol_dim1_reversed_of(shuffled), h2)));
  }
};

// Sampler::next_2d of sampler.h (kIndependent): eight PCG32 streams (rng.h), one per lane, each draw
// the scalar next_u32's operations (a 64-bit multiply-add of the state, the xorshift and the rotation).
struct IndependentLanes {
  U64 state, inc;
  U next_u32() {
    const U64 old = state;
    state = old * 0x5851f42d4c957f2dULL + inc;
    const U xorshifted = __builtin_convertvector(((old >> 18u) ^ old) >> 27u, U);
    const U rot = __builtin_convertvector(old >> 59u, U);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31u));
  }
  static F to_unit(U v) { return __builtin_convertvector(v >> 8, F) * 0x1p-24f; }  // u32_to_unit_float
  void next_2d(F& x, F& y) {
    x = to_unit(next_u32());
    y = to_unit(next_u32());
  }
  void load_lane(int i, const Sampler& s) {
    state[i] = s.rng.state;
    inc[i] = s.rng.inc;
  }
  void store_lane(int i, Sampler& s) const {
    s.type = SamplerType::kIndependent;
    s.rng.state = state[i];
    s.rng.inc = inc[i];
  }
  void after_scalar_vertex(int i, const Sampler& s) { state[i] = s.rng.state; }
  typedef U64 Saved;
  Saved save() const { return state; }
  void keep(M drew, Saved before) {
    typedef int64_t I64 __attribute__((vector_size(8 * kWidth)));
    state = __builtin_convertvector(drew, I64) ? state : before;
  }
  void init(uint32_t) {
    state = U64{};
    inc = U64{} + 1u;
  }
};

}  // namespace caustica::lanes
