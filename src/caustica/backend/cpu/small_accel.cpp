// SmallAccel (see small_accel.h). Each step of the eight-lane triangle test names the line of
// intersect_triangle (geometry/shapes.h) that it repeats.
#include "small_accel.h"

#include <cmath>
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

// The ray's part of intersect_triangle: the axis permutation and shear (lines 27-32).
struct RaySetup {
  int kx, ky, kz;
  float sx, sy, sz;
  float ox, oy, oz;
  bool ok;
  explicit RaySetup(const Ray& r) {
    // Without branches (a path tracer's rays point anywhere, so branches here would mispredict): the axes
    // from tables indexed by the three comparisons, the ray's components from arrays (Vec3f's operator[]
    // compiles to branches).
    const float d[3] = {r.d.x, r.d.y, r.d.z}, o[3] = {r.o.x, r.o.y, r.o.z};
    const float adx = std::fabs(d[0]), ady = std::fabs(d[1]), adz = std::fabs(d[2]);
    // kz = adx > ady ? (adx > adz ? 0 : 2) : (ady > adz ? 1 : 2); kx, ky the next axes after it, cyclically.
    static constexpr int8_t kZ[8] = {2, 1, 2, 1, 2, 2, 0, 0}, kX[8] = {0, 2, 0, 2, 0, 0, 1, 1},
                            kY[8] = {1, 0, 1, 0, 1, 1, 2, 2};
    const int c = (adx > ady) << 2 | (adx > adz) << 1 | (ady > adz);
    kz = kZ[c];
    kx = kX[c];
    ky = kY[c];
    // A negative d[kz] swaps kx and ky (keeps the winding).
    const int t = (kx ^ ky) & -int(d[kz] < 0.f);
    kx ^= t;
    ky ^= t;
    ok = !(d[kz] == 0.f);
    sz = 1.f / d[kz];
    sx = d[kx] * sz;
    sy = d[ky] * sz;
    ox = o[kx];
    oy = o[ky];
    oz = o[kz];
  }
};

inline F load(const float* p) { return *reinterpret_cast<const F*>(p); }
inline bool any_lane(M m) { return __builtin_ia32_movmskps256((F)m) != 0; }

// One block of eight triangles against the ray: hits closer than `tmax` (per lane) in `hit`, with their t
// and barycentrics. `valid` masks the block's unused lanes.
struct BlockHits {
  M hit;
  F t, b1, b2;
};
inline BlockHits test_block(const float (*p)[3][8], const RaySetup& r, F tmax, M valid) {
  // a = p0 - o, b = p1 - o, c = p2 - o, in the permuted axes (line 33).
  F akx = load(p[0][r.kx]) - r.ox, aky = load(p[0][r.ky]) - r.oy, akz = load(p[0][r.kz]) - r.oz;
  F bkx = load(p[1][r.kx]) - r.ox, bky = load(p[1][r.ky]) - r.oy, bkz = load(p[1][r.kz]) - r.oz;
  F ckx = load(p[2][r.kx]) - r.ox, cky = load(p[2][r.ky]) - r.oy, ckz = load(p[2][r.kz]) - r.oz;
  // Shear (lines 34-36).
  F ax = akx - r.sx * akz, ay = aky - r.sy * akz;
  F bx = bkx - r.sx * bkz, by = bky - r.sy * bkz;
  F cx = ckx - r.sx * ckz, cy = cky - r.sy * ckz;
  // Edge functions (lines 37-39).
  F u = cx * by - cy * bx;
  F v = ax * cy - ay * cx;
  F w = bx * ay - by * ax;
  // An edge function exactly 0: all three again in double (lines 40-44), lane by lane (rare).
  M zero = ((u == 0.f) | (v == 0.f) | (w == 0.f)) & valid;
  if (any_lane(zero)) {
    for (int i = 0; i < kWidth; ++i) {
      if (!zero[i]) continue;
      u[i] = float(double(cx[i]) * double(by[i]) - double(cy[i]) * double(bx[i]));
      v[i] = float(double(ax[i]) * double(cy[i]) - double(ay[i]) * double(cx[i]));
      w[i] = float(double(bx[i]) * double(ay[i]) - double(by[i]) * double(ax[i]));
    }
  }
  // Mixed signs miss (line 45).
  M neg = (u < 0.f) | (v < 0.f) | (w < 0.f), pos = (u > 0.f) | (v > 0.f) | (w > 0.f);
  M ok = valid & ~(neg & pos);
  if (!any_lane(ok)) return {ok, F{}, F{}, F{}};
  // Determinant (lines 46-47).
  F det = u + v + w;
  ok &= (det != 0.f) & finite(det);
  // Scaled distance and its range (lines 48-50).
  F az = r.sz * akz, bz = r.sz * bkz, cz = r.sz * ckz;
  F tt = u * az + v * bz + w * cz;
  F td = tmax * det;
  M neg_det = det < 0.f;
  M out = neg_det ? ((tt >= 0.f) | ~(tt > td)) : ((tt <= 0.f) | ~(tt < td));
  ok &= ~out;
  // Distance and barycentrics (lines 51-56).
  F inv = 1.f / det;
  F th = tt * inv;
  ok &= (th > 0.f) & (th < tmax);
  return {ok, th, v * inv, w * inv};
}

}  // namespace

bool SmallAccel::intersect(const Ray& ray, Hit& hit) const {
  hit = Hit();
  Ray r = ray;
  const RaySetup rs(ray);
  if (rs.ok) {
    F best_t = splat(ray.tmax), best_b1 = splat(0.f), best_b2 = splat(0.f);
    M best_i = none() - 1;  // -1: none
    for (const Block& blk : blocks_) {
      const M prim = *reinterpret_cast<const M*>(blk.prim);
      BlockHits h = test_block(blk.p, rs, best_t, prim >= 0);
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
    int lane = closest ? __builtin_ctz(closest) : -1;
    for (int c = closest & (closest - 1); c; c &= c - 1) {  // equal distances (rare)
      int i = __builtin_ctz(c);
      if (best_i[i] < best_i[lane]) lane = i;
    }
    if (lane >= 0) {
      hit.t = best_t[lane];
      hit.prim = uint32_t(best_i[lane]);
      hit.b1 = best_b1[lane];
      hit.b2 = best_b2[lane];
      r.tmax = hit.t;
    }
  }
  for (uint32_t i = 0; i < spheres_.size(); ++i) {
    float t;
    if (!intersect_sphere(r, spheres_[i], t)) continue;
    r.tmax = t;
    hit.t = t;
    hit.prim = num_triangles_ + i;
    hit.b1 = hit.b2 = 0.f;
  }
  return hit.valid();
}

bool SmallAccel::occluded(const Ray& ray) const {
  const RaySetup rs(ray);
  if (rs.ok) {
    const F tmax = splat(ray.tmax);
    for (const Block& blk : blocks_)
      if (any_lane(test_block(blk.p, rs, tmax, *reinterpret_cast<const M*>(blk.prim) >= 0).hit)) return true;
  }
  for (const Sphere& s : spheres_) {
    float t;
    if (intersect_sphere(ray, s, t)) return true;
  }
  return false;
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

}  // namespace caustica

#endif
