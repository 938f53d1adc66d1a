// The portable ray/triangle test (geometry/shapes.h), which the GPU BVH uses:
// watertight on shared edges and vertices (Woop, Benthin, Wald 2013), and
// agreeing with a double-precision reference on the hit distance and barycentrics;
// and Embree, as caustica sets it up, watertight on the same kind of rays.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "caustica/base/rng.h"
#include "caustica/base/sampling.h"
#include "caustica/backend/cpu/cpu_accel.h"
#include "caustica/geometry/shapes.h"

using namespace caustica;

namespace {

// A closed, finely triangulated box: every edge of the grid is shared by two triangles.
struct Mesh {
  std::vector<Vec3f> p;
  std::vector<uint32_t> idx;
};

Mesh closed_box(Vec3f lo, Vec3f hi, int n) {
  Mesh m;
  auto quad_grid = [&](Vec3f o, Vec3f du, Vec3f dv) {
    uint32_t base = uint32_t(m.p.size());
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) m.p.push_back(o + du * (float(i) / n) + dv * (float(j) / n));
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        uint32_t a = base + uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n + 2), d = a + uint32_t(n + 1);
        m.idx.insert(m.idx.end(), {a, b, c, a, c, d});
      }
  };
  Vec3f e = hi - lo;
  quad_grid(lo, Vec3f(e.x, 0, 0), Vec3f(0, e.y, 0));                      // z = lo
  quad_grid(Vec3f(lo.x, lo.y, hi.z), Vec3f(e.x, 0, 0), Vec3f(0, e.y, 0));  // z = hi
  quad_grid(lo, Vec3f(e.x, 0, 0), Vec3f(0, 0, e.z));                      // y = lo
  quad_grid(Vec3f(lo.x, hi.y, lo.z), Vec3f(e.x, 0, 0), Vec3f(0, 0, e.z));  // y = hi
  quad_grid(lo, Vec3f(0, e.y, 0), Vec3f(0, 0, e.z));                      // x = lo
  quad_grid(Vec3f(hi.x, lo.y, lo.z), Vec3f(0, e.y, 0), Vec3f(0, 0, e.z));  // x = hi
  return m;
}

bool hits_any(const Mesh& m, const Ray& r) {
  for (size_t k = 0; k < m.idx.size(); k += 3) {
    float t, b1, b2;
    if (intersect_triangle(r, m.p[m.idx[k]], m.p[m.idx[k + 1]], m.p[m.idx[k + 2]], t, b1, b2)) return true;
  }
  return false;
}

// Rays from points inside a closed box aimed exactly at its mesh vertices (every
// fourth) and at points on its triangles' edges. The box is off the origin with
// non-dyadic extents so that the float arithmetic is not exact; every edge of its
// grid is shared by two triangles.
const Vec3f kBoxLo(-0.731f, 0.113f, 2.377f), kBoxHi(1.419f, 1.977f, 4.251f);

std::vector<Ray> rays_at_edges_and_vertices(const Mesh& m, int n) {
  PCG32 rng(21, 3);
  Vec3f ext = kBoxHi - kBoxLo;
  std::vector<Ray> rays;
  for (int trial = 0; trial < n; ++trial) {
    Vec3f o(kBoxLo.x + ext.x * (0.2f + 0.6f * rng.next_float()), kBoxLo.y + ext.y * (0.2f + 0.6f * rng.next_float()),
            kBoxLo.z + ext.z * (0.2f + 0.6f * rng.next_float()));
    size_t k = 3 * (rng.next_u32() % uint32_t(m.idx.size() / 3));
    int e = int(rng.next_u32() % 3);
    Vec3f a = m.p[m.idx[k + e]], b = m.p[m.idx[k + (e + 1) % 3]];
    float s = trial % 4 == 0 ? 0.f : rng.next_float();
    Vec3f target = a + (b - a) * s;
    rays.push_back(Ray{o, normalize(target - o), kInf});
  }
  return rays;
}

}  // namespace

// All of those rays must hit: a leak would let light through closed geometry.
TEST(Triangle, WatertightOnSharedEdgesAndVertices) {
  Mesh m = closed_box(kBoxLo, kBoxHi, 6);
  std::vector<Ray> rays = rays_at_edges_and_vertices(m, 4000);
  int misses = 0;
  for (const Ray& r : rays) misses += !hits_any(m, r);
  EXPECT_EQ(misses, 0) << "of " << rays.size() << " rays aimed at shared edges and vertices";
}

// More of the same rays through Embree as caustica configures it (cpu_accel.cpp:
// robust mode), for closest-hit and occlusion queries. Embree's faster default mode
// lets 3161 of these 20000 through (measured by switching the flag off).
namespace {
void expect_watertight(const Mesh& m, CpuAccel::Kind kind) {
  SceneView v;
  v.positions = m.p.data();
  v.indices = m.idx.data();
  v.num_triangles = uint32_t(m.idx.size() / 3);
  CpuAccel accel(v, kind);
  ASSERT_EQ(accel.kind(), kind);
  std::vector<Ray> rays = rays_at_edges_and_vertices(m, 20000);
  int misses = 0, unoccluded = 0;
  for (const Ray& r : rays) {
    Hit h;
    misses += !accel.intersect(r, h);
    unoccluded += !accel.occluded(r);
  }
  EXPECT_EQ(misses, 0) << "of " << rays.size() << " rays aimed at shared edges and vertices";
  EXPECT_EQ(unoccluded, 0) << "of " << rays.size() << " rays aimed at shared edges and vertices";
}
}  // namespace

TEST(Triangle, EmbreeWatertightOnSharedEdgesAndVertices) {
  expect_watertight(closed_box(kBoxLo, kBoxHi, 6), CpuAccel::Kind::kEmbree);
}

// The same through the small-scene test (small_accel.h), on a box of 48 triangles (it takes at most 64).
TEST(Triangle, SmallAccelWatertightOnSharedEdgesAndVertices) {
  if (!SmallAccel::available()) GTEST_SKIP() << "this CPU lacks AVX2, which the small-scene test needs";
  Mesh m = closed_box(kBoxLo, kBoxHi, 2);
  ASSERT_EQ(m.idx.size() / 3, 48u);
  expect_watertight(m, CpuAccel::Kind::kSmall);
}

// Hit distance and barycentrics against a double-precision Moller-Trumbore on random
// rays through random well-conditioned triangles (well inside: barycentrics >= 0.01;
// no slivers, no grazing rays), to 1e-4 (relative for t).
TEST(Triangle, AgreesWithDoublePrecision) {
  PCG32 rng(8, 1);
  int hits = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    Vec3f p[3];
    for (auto& q : p) q = Vec3f(rng.next_float(), rng.next_float(), rng.next_float()) * 4.f - Vec3f(2.f);
    float u = 0.01f + 0.98f * rng.next_float(), v = 0.01f + 0.98f * rng.next_float();
    if (u + v > 0.99f) u = 0.99f - u, v = std::fabs(0.99f - v) * 0.5f;
    if (u < 0.01f || v < 0.01f || u + v > 0.99f) continue;
    Vec3f target = p[0] * (1.f - u - v) + p[1] * u + p[2] * v;
    Vec3f o = target + square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float())) * (0.5f + 3.f * rng.next_float());
    Ray r{o, normalize(target - o), kInf};
    // Reference in double.
    double e1[3], e2[3], d[3], tv[3];
    for (int a = 0; a < 3; ++a)
      e1[a] = double(p[1][a]) - p[0][a], e2[a] = double(p[2][a]) - p[0][a], d[a] = r.d[a], tv[a] = double(r.o[a]) - p[0][a];
    auto cr = [](const double* x, const double* y, double* z) {
      z[0] = x[1] * y[2] - x[2] * y[1], z[1] = x[2] * y[0] - x[0] * y[2], z[2] = x[0] * y[1] - x[1] * y[0];
    };
    auto dt = [](const double* x, const double* y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
    double pv[3], qv[3];
    cr(d, e2, pv);
    double det = dt(e1, pv);
    // Well-conditioned cases only (float error grows as 1/|det|): triangles not slivers, rays not grazing.
    double n[3];
    cr(e1, e2, n);
    double area2 = std::sqrt(dt(n, n)), l1 = std::sqrt(dt(e1, e1)), l2 = std::sqrt(dt(e2, e2));
    if (area2 < 0.2 * l1 * l2 || std::fabs(det) < 0.2 * area2) continue;
    cr(tv, e1, qv);
    double ru = dt(tv, pv) / det, rv = dt(d, qv) / det, rt = dt(e2, qv) / det;
    float t, b1, b2;
    ASSERT_TRUE(intersect_triangle(r, p[0], p[1], p[2], t, b1, b2)) << trial;
    ++hits;
    EXPECT_NEAR(t, rt, 1e-4 * std::max(1.0, rt)) << trial;
    EXPECT_NEAR(b1, ru, 1e-4) << trial;
    EXPECT_NEAR(b2, rv, 1e-4) << trial;
    // Beyond tmax or behind the origin: no hit.
    Ray shorter = r;
    shorter.tmax = float(rt) * 0.999f;
    EXPECT_FALSE(intersect_triangle(shorter, p[0], p[1], p[2], t, b1, b2)) << trial;
    Ray back{o, -r.d, kInf};
    EXPECT_FALSE(intersect_triangle(back, p[0], p[1], p[2], t, b1, b2)) << trial;
  }
  EXPECT_GT(hits, 3000);
}
