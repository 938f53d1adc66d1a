// SmallAccel (see small_accel.h). Each step of the eight-lane triangle test names the line of
// intersect_triangle (geometry/shapes.h) that it repeats.
#include "small_accel.h"

#include <array>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <stdexcept>
#include <string>

#include "../../base/avx2.h"
#include "../../geometry/shapes.h"

namespace caustica {

SmallAccel::SmallAccel(const SceneView& v) : num_triangles_(v.num_triangles), spheres_(v.spheres, v.spheres + v.num_spheres) {
  if (v.num_triangles > kMaxTriangles)
    throw std::invalid_argument("SmallAccel: more than " + std::to_string(kMaxTriangles) + " triangles");
  // In the scene's order (a shape's triangles are adjacent); the last block's unused lanes get index -1.
  blocks_.resize((v.num_triangles + 7) / 8);
  for (Block& b : blocks_)
    for (int l = 0; l < 8; ++l) b.prim[l] = -1;
  for (uint32_t t = 0; t < v.num_triangles; ++t) {
    Block& b = blocks_[t / 8];
    b.prim[t % 8] = int32_t(t);
    b.valid |= 1 << (t % 8);
    for (int k = 0; k < 3; ++k) {
      Vec3f p = v.positions[v.indices[3 * t + k]];
      for (int a = 0; a < 3; ++a) b.p[k][a][t % 8] = p[a];
    }
  }
}

#if CAUSTICA_AVX2_BUILD

bool SmallAccel::available() { return cpu_has_avx2(); }

}  // namespace caustica

// From here to CAUSTICA_AVX2_END, AVX2 (called only after available()); the scalar headers were included
// above.
CAUSTICA_AVX2_BEGIN
#include "../../base/lanes.h"

namespace caustica {
namespace {
using namespace lanes;

// The axis permutation of intersect_triangle (lines 27-29) for each outcome of its three comparisons of
// |d| (bit 0: |dx| > |dy|, bit 1: |dx| > |dz|, bit 2: |dy| > |dz|; index bits 3-5) and each sign of d's
// components (index bits 0-2; that of d[kz] swaps kx and ky): {kx, ky, kz, 3}, also a vpermilps control
// that moves d[kx], d[ky], d[kz] to lanes 0-2.
struct Permutation {
  alignas(16) int32_t k[4];
};
constexpr std::array<Permutation, 64> permutations() {
  std::array<Permutation, 64> t{};
  for (int c = 0; c < 8; ++c)
    for (int sign = 0; sign < 8; ++sign) {
      const bool x_gt_y = c & 1, x_gt_z = c & 2, y_gt_z = c & 4;
      const int kz = x_gt_y ? (x_gt_z ? 0 : 2) : (y_gt_z ? 1 : 2);
      int kx = kz == 2 ? 0 : kz + 1, ky = kx == 2 ? 0 : kx + 1;
      if (sign >> kz & 1) { const int tmp = kx; kx = ky; ky = tmp; }
      t[c << 3 | sign] = Permutation{{kx, ky, kz, 3}};
    }
  return t;
}
constexpr std::array<Permutation, 64> kPermutations = permutations();

// The ray's part of intersect_triangle: the axis permutation and shear (lines 27-32).
struct RaySetup {
  int kx, ky, kz;
  float sx, sy, sz;
  float ox, oy, oz;
  bool ok;
  RaySetup() = default;
  explicit RaySetup(const Ray& r) {
    // Without branches (a path tracer's rays point anywhere, so branches here would mispredict) and in one
    // SSE register: the comparisons and signs as bit masks, which index the permutation table, whose entry
    // then permutes d and o. Line 28 swaps kx and ky where d[kz] < 0, this where d[kz]'s sign bit is set;
    // the two differ only for -0 and NaN, and a ray whose d[kz] is either hits nothing (d[kz] has the largest
    // magnitude, so -0 means d = 0; a NaN makes every edge function NaN).
    typedef float F4 __attribute__((vector_size(16)));
    typedef int32_t I4 __attribute__((vector_size(16)));
    static_assert(offsetof(Ray, d) == 12 && offsetof(Ray, tmax) == 24, "Ray: o, d, tmax packed");
    F4 d, o;  // d.xyz and tmax; o.xyz and d.x (lane 3 unused)
    std::memcpy(&d, reinterpret_cast<const char*>(&r) + offsetof(Ray, d), sizeof d);
    std::memcpy(&o, reinterpret_cast<const char*>(&r) + offsetof(Ray, o), sizeof o);
    const F4 a = (F4)((I4)d & 0x7fffffff);
    const F4 lhs = __builtin_shufflevector(a, a, 0, 0, 1, 3), rhs = __builtin_shufflevector(a, a, 1, 2, 2, 3);
    const int c = __builtin_ia32_movmskps((F4)(lhs > rhs)) & 7, sign = __builtin_ia32_movmskps(d) & 7;
    const Permutation& p = kPermutations[c << 3 | sign];
    kx = p.k[0];
    ky = p.k[1];
    kz = p.k[2];
    const I4 ctrl = *reinterpret_cast<const I4*>(p.k);
    const F4 dp = __builtin_ia32_vpermilvarps(d, ctrl), op = __builtin_ia32_vpermilvarps(o, ctrl);
    ok = !(dp[2] == 0.f);
    sz = 1.f / dp[2];
    sx = dp[0] * sz;
    sy = dp[1] * sz;
    ox = op[0];
    oy = op[1];
    oz = op[2];
  }
};

inline F load(const float* p) { return *reinterpret_cast<const F*>(p); }

// RaySetup for eight rays at once, lane for lane the same values (the same choices, the same IEEE
// operations).
struct RaySetups {
  alignas(32) int32_t kx[8], ky[8], kz[8];
  alignas(32) float sx[8], sy[8], sz[8], ox[8], oy[8], oz[8];
  int ok;  // bit per lane
  explicit RaySetups(const RayLanes& r) {
    const F dx = load(r.dx), dy = load(r.dy), dz = load(r.dz);
    const F ax = vfabs(dx), ay = vfabs(dy), az = vfabs(dz);
    // kz = |dx| > |dy| ? (|dx| > |dz| ? 0 : 2) : (|dy| > |dz| ? 1 : 2) (line 27)
    const M x_gt_y = ax > ay, kz0 = x_gt_y & (ax > az), kz1 = ~x_gt_y & (ay > az);
    const M kz_v = kz0 ? M{} : (kz1 ? M{} + 1 : M{} + 2);
    const F dkz = kz0 ? dx : (kz1 ? dy : dz);
    // kx, ky: the next axes after kz, cyclically; swapped where d[kz]'s sign bit is set (RaySetup's rule).
    const M kx_n = kz0 ? M{} + 1 : (kz1 ? M{} + 2 : M{}), ky_n = kz0 ? M{} + 2 : (kz1 ? M{} : M{} + 1);
    const M swap = (M)dkz >> 31;
    const M kx_v = swap ? ky_n : kx_n, ky_v = swap ? kx_n : ky_n;
    const F ox_a = load(r.ox), oy_a = load(r.oy), oz_a = load(r.oz);
    auto pick = [](M k, F x, F y, F z) { return k == 0 ? x : (k == 1 ? y : z); };
    const F szv = 1.f / dkz;
    *reinterpret_cast<M*>(kx) = kx_v;
    *reinterpret_cast<M*>(ky) = ky_v;
    *reinterpret_cast<M*>(kz) = kz_v;
    *reinterpret_cast<F*>(sz) = szv;
    *reinterpret_cast<F*>(sx) = pick(kx_v, dx, dy, dz) * szv;
    *reinterpret_cast<F*>(sy) = pick(ky_v, dx, dy, dz) * szv;
    *reinterpret_cast<F*>(ox) = pick(kx_v, ox_a, oy_a, oz_a);
    *reinterpret_cast<F*>(oy) = pick(ky_v, ox_a, oy_a, oz_a);
    *reinterpret_cast<F*>(oz) = kz0 ? ox_a : (kz1 ? oy_a : oz_a);
    ok = ~__builtin_ia32_movmskps256((F)(dkz == 0.f)) & 0xff;
  }
  RaySetup lane(int i) const {
    RaySetup s;
    s.kx = kx[i];
    s.ky = ky[i];
    s.kz = kz[i];
    s.sx = sx[i];
    s.sy = sy[i];
    s.sz = sz[i];
    s.ox = ox[i];
    s.oy = oy[i];
    s.oz = oz[i];
    s.ok = ok >> i & 1;
    return s;
  }
};

inline bool any_lane(M m) { return __builtin_ia32_movmskps256((F)m) != 0; }
inline int sign_bits(F x) { return __builtin_ia32_movmskps256(x); }
inline int sign_bits(M m) { return __builtin_ia32_movmskps256((F)m); }

// The edge functions of one block of eight triangles for the ray (lines 33-39): the vertices relative to the
// origin in the permuted axes, sheared, then U, V, W.
struct Edges {
  F u, v, w;
};
inline Edges edge_functions(const float (*p)[3][8], const RaySetup& r) {
  // -a = o - p0, -b = o - p1, -c = o - p2, in the permuted axes (line 33, negated: the vertex is then the
  // subtrahend, which x86 takes from memory, one instruction instead of a load and a subtraction).
  F akx = r.ox - load(p[0][r.kx]), aky = r.oy - load(p[0][r.ky]), akz = r.oz - load(p[0][r.kz]);
  F bkx = r.ox - load(p[1][r.kx]), bky = r.oy - load(p[1][r.ky]), bkz = r.oz - load(p[1][r.kz]);
  F ckx = r.ox - load(p[2][r.kx]), cky = r.oy - load(p[2][r.ky]), ckz = r.oz - load(p[2][r.kz]);
  // Shear (lines 34-36), giving -ax, -ay, ... exactly (rounding to nearest is symmetric about 0).
  F ax = akx - r.sx * akz, ay = aky - r.sy * akz;
  F bx = bkx - r.sx * bkz, by = bky - r.sy * bkz;
  F cx = ckx - r.sx * ckz, cy = cky - r.sy * ckz;
  // Edge functions (lines 37-39): products of two negated values, so U, V, W themselves, bit for bit.
  return {cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax};
}

// Lanes whose edge functions have mixed signs (they miss, line 45), where some lane's edge function came out
// exactly 0: those lanes' three edge functions again in double (lines 40-44), then the comparisons of line
// 45 as written. Rare, so out of line: the common path then keeps nothing alive for it (the inlined version
// spilled the sheared vertices of every block to the stack).
[[gnu::noinline]] int mixed_signs_exact(const float (*p)[3][8], const RaySetup& r, int zero, Edges& e) {
  const F akx = load(p[0][r.kx]) - r.ox, aky = load(p[0][r.ky]) - r.oy, akz = load(p[0][r.kz]) - r.oz;
  const F bkx = load(p[1][r.kx]) - r.ox, bky = load(p[1][r.ky]) - r.oy, bkz = load(p[1][r.kz]) - r.oz;
  const F ckx = load(p[2][r.kx]) - r.ox, cky = load(p[2][r.ky]) - r.oy, ckz = load(p[2][r.kz]) - r.oz;
  const F ax = akx - r.sx * akz, ay = aky - r.sy * akz;
  const F bx = bkx - r.sx * bkz, by = bky - r.sy * bkz;
  const F cx = ckx - r.sx * ckz, cy = cky - r.sy * ckz;
  for (int i = 0; i < kWidth; ++i) {
    if (!(zero >> i & 1)) continue;
    e.u[i] = float(double(cx[i]) * double(by[i]) - double(cy[i]) * double(bx[i]));
    e.v[i] = float(double(ax[i]) * double(cy[i]) - double(ay[i]) * double(cx[i]));
    e.w[i] = float(double(bx[i]) * double(ay[i]) - double(by[i]) * double(ax[i]));
  }
  const F z = splat(0.f);
  return sign_bits(((e.u < z) | (e.v < z) | (e.w < z)) & ((e.u > z) | (e.v > z) | (e.w > z)));
}

// Phase 1: the lanes (bits) of the block's triangles that the ray may hit, as far as the edge functions tell
// (lines 33-45); `valid` holds the bits of the block's used lanes. Where no edge function is 0, "some
// negative and some positive" is "not all of one sign bit", two XORs; lanes with a NaN may pass here and
// fail the determinant's finiteness in phase 2, as the scalar test rejects them (a NaN edge function makes
// det NaN).
inline int candidates(const float (*p)[3][8], const RaySetup& r, int valid, Edges& e) {
  e = edge_functions(p, r);
  const F z = splat(0.f);
  const int zero = sign_bits((e.u == z) | (e.v == z) | (e.w == z)) & valid;
  if (zero) {
    Edges x = e;  // (a copy: e's address taken here would keep e in memory on the common path too)
    const int mixed = mixed_signs_exact(p, r, zero, x);
    e = x;
    return valid & ~mixed;
  }
  return valid & ~sign_bits((F)(((U)e.u ^ (U)e.v) | ((U)e.u ^ (U)e.w)));
}

// Phase 2, for a block with candidates `ok` (bits) and their edge functions: the determinant, the distance
// and its range (lines 46-56). Hits closer than `tmax` (per lane) in `hit`, with their t and barycentrics.
struct BlockHits {
  M hit;
  F t, b1, b2;
};
inline BlockHits finish_block(const float (*p)[3][8], const RaySetup& r, F tmax, int ok_bits, const Edges& e) {
  M ok = mask_of_bits(ok_bits);
  const F u = e.u, v = e.v, w = e.w;
  // Determinant (lines 46-47).
  F det = u + v + w;
  ok &= (det != 0.f) & finite(det);
  // Scaled distance and its range (lines 48-50).
  F az = r.sz * (load(p[0][r.kz]) - r.oz), bz = r.sz * (load(p[1][r.kz]) - r.oz),
    cz = r.sz * (load(p[2][r.kz]) - r.oz);
  F tt = u * az + v * bz + w * cz;
  F td = tmax * det;
  // Line 50's two cases as one: where det < 0, tt and td with their signs flipped (exact; lanes with det 0 or
  // NaN are out already).
  const U sign = (U)det & 0x80000000u;
  const F ts = (F)((U)tt ^ sign), tds = (F)((U)td ^ sign);
  M out = (ts <= 0.f) | ~(ts < tds);
  ok &= ~out;
  // Distance and barycentrics (lines 51-56).
  F inv = 1.f / det;
  F th = tt * inv;
  ok &= (th > 0.f) & (th < tmax);
  return {ok, th, v * inv, w * inv};
}

// The triangles' closest hit (into hit, left as it is when none is closer than tmax).
inline void closest_triangle(const std::vector<SmallAccel::Block>& blocks, const RaySetup& rs, float tmax,
                             Hit& hit) {
  F best_t = splat(tmax), best_b1 = splat(0.f), best_b2 = splat(0.f);
  M best_i = none() - 1;  // -1: none
  for (const SmallAccel::Block& blk : blocks) {
    Edges e;
    const int ok = candidates(blk.p, rs, blk.valid, e);
    if (!ok) continue;
    const M prim = *reinterpret_cast<const M*>(blk.prim);
    BlockHits h = finish_block(blk.p, rs, best_t, ok, e);
    best_t = sel(h.hit, h.t, best_t);
    best_b1 = sel(h.hit, h.b1, best_b1);
    best_b2 = sel(h.hit, h.b2, best_b2);
    best_i = h.hit ? prim : best_i;
  }
  // The closest of the eight lanes' hits; at equal t, the lowest primitive index.
  F m = vminf(best_t, __builtin_shufflevector(best_t, best_t, 4, 5, 6, 7, 0, 1, 2, 3));
  m = vminf(m, __builtin_shufflevector(m, m, 2, 3, 0, 1, 6, 7, 4, 5));
  m = vminf(m, __builtin_shufflevector(m, m, 1, 0, 3, 2, 5, 4, 7, 6));
  int closest = __builtin_ia32_movmskps256((F)((best_t == m) & (best_i >= 0)));
  if (!closest) return;
  int lane = __builtin_ctz(closest);
  for (int c = closest & (closest - 1); c; c &= c - 1) {  // equal distances (rare)
    int i = __builtin_ctz(c);
    if (best_i[i] < best_i[lane]) lane = i;
  }
  hit.t = best_t[lane];
  hit.prim = uint32_t(best_i[lane]);
  hit.b1 = best_b1[lane];
  hit.b2 = best_b2[lane];
}

inline bool any_triangle(const std::vector<SmallAccel::Block>& blocks, const RaySetup& rs, float tmax_s) {
  const F tmax = splat(tmax_s);
  for (const SmallAccel::Block& blk : blocks) {
    Edges e;
    const int ok = candidates(blk.p, rs, blk.valid, e);
    if (ok && any_lane(finish_block(blk.p, rs, tmax, ok, e).hit)) return true;
  }
  return false;
}

}  // namespace

// The spheres after the triangles: a closer sphere replaces the triangles' hit.
void SmallAccel::closest_sphere(Ray r, Hit& hit) const {
  if (hit.valid()) r.tmax = hit.t;
  for (uint32_t i = 0; i < spheres_.size(); ++i) {
    float t;
    if (!intersect_sphere(r, spheres_[i], t)) continue;
    r.tmax = t;
    hit.t = t;
    hit.prim = num_triangles_ + i;
    hit.b1 = hit.b2 = 0.f;
  }
}

bool SmallAccel::any_sphere(const Ray& ray) const {
  for (const Sphere& s : spheres_) {
    float t;
    if (intersect_sphere(ray, s, t)) return true;
  }
  return false;
}

bool SmallAccel::intersect(const Ray& ray, Hit& hit) const {
  hit = Hit();
  const RaySetup rs(ray);
  if (rs.ok) closest_triangle(blocks_, rs, ray.tmax, hit);
  if (!spheres_.empty()) closest_sphere(ray, hit);
  return hit.valid();
}

bool SmallAccel::occluded(const Ray& ray) const {
  const RaySetup rs(ray);
  if (rs.ok && any_triangle(blocks_, rs, ray.tmax)) return true;
  return !spheres_.empty() && any_sphere(ray);
}

void SmallAccel::intersect8(const RayLanes& rays, int mask, Hit hits[8]) const {
  const RaySetups rs(rays);
  for (int m = mask; m; m &= m - 1) {
    const int i = __builtin_ctz(m);
    hits[i] = Hit();
    if (rs.ok >> i & 1) closest_triangle(blocks_, rs.lane(i), rays.tmax[i], hits[i]);
    if (!spheres_.empty()) closest_sphere(rays.ray(i), hits[i]);
  }
}

int SmallAccel::occluded8(const RayLanes& rays, int mask) const {
  const RaySetups rs(rays);
  int occluded = 0;
  for (int m = mask; m; m &= m - 1) {
    const int i = __builtin_ctz(m);
    if (((rs.ok >> i & 1) && any_triangle(blocks_, rs.lane(i), rays.tmax[i])) ||
        (!spheres_.empty() && any_sphere(rays.ray(i))))
      occluded |= 1 << i;
  }
  return occluded;
}

}  // namespace caustica

CAUSTICA_AVX2_END

#else  // !CAUSTICA_AVX2_BUILD

bool SmallAccel::available() { return false; }
bool SmallAccel::intersect(const Ray&, Hit& hit) const {
  hit = Hit();
  return false;
}
bool SmallAccel::occluded(const Ray&) const { return false; }
void SmallAccel::intersect8(const RayLanes&, int mask, Hit hits[8]) const {
  for (int i = 0; i < 8; ++i)
    if (mask >> i & 1) hits[i] = Hit();
}
int SmallAccel::occluded8(const RayLanes&, int) const { return 0; }

}  // namespace caustica

#endif
