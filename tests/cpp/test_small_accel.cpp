// The small-scene accelerator (backend/cpu/small_accel.h) against the portable BVH, whose triangle test it
// repeats eight lanes at a time, and CpuAccel's choice between it and Embree.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "caustica/backend/cpu/cpu_accel.h"
#include "caustica/backend/cpu/small_accel.h"
#include "caustica/base/rng.h"
#include "caustica/base/sampling.h"
#include "caustica/geometry/shapes.h"
#include "caustica/scene/builtin/builtin.h"
#include "caustica/scene/intersect.h"
#include "caustica/scene/scene.h"

using namespace caustica;

namespace {

#define REQUIRE_AVX2() \
  if (!SmallAccel::available()) GTEST_SKIP() << "this CPU lacks AVX2, which the small-scene test needs"

// A flat scene of loose triangles (and spheres) for the accelerators; the arrays stay owned here.
struct Soup {
  std::vector<Vec3f> p;
  std::vector<uint32_t> idx;
  std::vector<Sphere> spheres;
  SceneView view() const {
    SceneView v;
    v.positions = p.data();
    v.indices = idx.data();
    v.num_triangles = uint32_t(idx.size() / 3);
    v.spheres = spheres.data();
    v.num_spheres = uint32_t(spheres.size());
    return v;
  }
  void add(Vec3f a, Vec3f b, Vec3f c) {
    for (Vec3f q : {a, b, c}) {
      idx.push_back(uint32_t(p.size()));
      p.push_back(q);
    }
  }
};

// n random triangles of size ~0.6 in [-1, 1]^3.
Soup random_soup(int n, uint64_t seed) {
  Soup s;
  PCG32 rng(seed, 1);
  auto u = [&] { return rng.next_float() * 2.f - 1.f; };
  for (int i = 0; i < n; ++i) {
    Vec3f c(u(), u(), u());
    s.add(c + Vec3f(u(), u(), u()) * 0.3f, c + Vec3f(u(), u(), u()) * 0.3f, c + Vec3f(u(), u(), u()) * 0.3f);
  }
  return s;
}

// Closest hits and occlusion of random rays from inside `bounds`, small-scene test against the portable BVH
// (a BVH must be built for the view). Where both name the same primitive, distance and barycentrics must be
// bit for bit the same (the same triangle test); where they differ, it must be a tie (see below).
void expect_agreement(const SceneView& v, const SmallAccel& small, const char* what, int n = 20000) {
  BVHAccel bvh{&v};
  PCG32 rng(3, 5);
  int hits = 0, ties = 0;
  const Vec3f lo = v.bounds.lo, ext = v.bounds.diagonal();
  for (int k = 0; k < n; ++k) {
    Ray r;
    r.o = lo + Vec3f(rng.next_float() * ext.x, rng.next_float() * ext.y, rng.next_float() * ext.z);
    r.d = square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float()));
    r.tmax = k % 3 == 0 ? 0.5f * length(ext) * rng.next_float() : kInf;  // some segments
    Hit hs, hb;
    bool a = small.intersect(r, hs), b = bvh.intersect(r, hb);
    ASSERT_EQ(a, b) << what << " ray " << k;
    EXPECT_EQ(small.occluded(r), a) << what << " ray " << k;
    if (!a) {
      EXPECT_FALSE(hs.valid());
      continue;
    }
    ++hits;
    if (hs.prim == hb.prim) {
      EXPECT_EQ(hs.t, hb.t) << what << " ray " << k;
      EXPECT_EQ(hs.b1, hb.b1) << what << " ray " << k;
      EXPECT_EQ(hs.b2, hb.b2) << what << " ray " << k;
    } else {
      // A tie to within rounding (coplanar faces, such as the small box's bottom on the cornell floor, or
      // shared edges): the distances agree to 1e-5 (relative), and the small-scene test's primitive, tested
      // alone by the scalar test, is hit at the distance it reported.
      ++ties;
      EXPECT_NEAR(hs.t, hb.t, 1e-5f * std::max(1.f, hb.t)) << what << " ray " << k << ": prims " << hs.prim
                                                           << " and " << hb.prim;
      Hit single;
      Ray rr = r;
      ASSERT_TRUE((PrimIntersector{&v, &single}(hs.prim, rr))) << what << " ray " << k;
      EXPECT_EQ(single.t, hs.t) << what << " ray " << k;
    }
  }
  EXPECT_GT(hits, n / 10) << what;
  EXPECT_LT(ties, n / 100) << what;  // ties (shared edges, coplanar faces) are rare on random rays

  // Eight rays at once (intersect8, occluded8, whose ray set-up runs in lanes) answer as one at a time, bit
  // for bit, for the lanes asked (a random mask), and leave the others' hits alone. Among the rays: axis-
  // aligned ones with +0 and -0 components (the set-up's choice of axes and its sign rule), a zero and a
  // NaN direction.
  for (int k = 0; k < n / 8; ++k) {
    RayLanes rl;
    for (int i = 0; i < 8; ++i) {
      Ray r;
      r.o = lo + Vec3f(rng.next_float() * ext.x, rng.next_float() * ext.y, rng.next_float() * ext.z);
      r.d = square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float()));
      const uint32_t kind = rng.next_u32() % 16;
      if (kind == 0) r.d = Vec3f(0.f, 0.f, rng.next_float() < 0.5f ? 1.f : -1.f);
      if (kind == 1) r.d = Vec3f(-0.f, rng.next_float() < 0.5f ? 1.f : -1.f, -0.f);
      if (kind == 2) r.d = Vec3f(rng.next_float() < 0.5f ? 1.f : -1.f, 0.f, -0.f);
      if (kind == 3) r.d = Vec3f(0.f);
      if (kind == 4) r.d = Vec3f(std::nanf(""), 0.5f, 0.5f);
      if (kind == 5) r.d.x = -0.f;
      r.tmax = kind == 6 ? 0.5f * length(ext) * rng.next_float() : kInf;
      rl.ox[i] = r.o.x, rl.oy[i] = r.o.y, rl.oz[i] = r.o.z;
      rl.dx[i] = r.d.x, rl.dy[i] = r.d.y, rl.dz[i] = r.d.z;
      rl.tmax[i] = r.tmax;
    }
    const int mask = int(rng.next_u32() & 0xff);
    Hit hits[8];
    for (Hit& h : hits) h = Hit{-1.f, 12345u, -1.f, -1.f};  // a sentinel for the lanes not asked
    small.intersect8(rl, mask, hits);
    const int occluded = small.occluded8(rl, mask);
    for (int i = 0; i < 8; ++i) {
      if (!(mask >> i & 1)) {
        EXPECT_EQ(hits[i].prim, 12345u) << what << " batch " << k << " lane " << i;
        EXPECT_FALSE(occluded >> i & 1) << what << " batch " << k << " lane " << i;
        continue;
      }
      Hit one;
      const bool a = small.intersect(rl.ray(i), one);
      ASSERT_EQ(hits[i].valid(), a) << what << " batch " << k << " lane " << i;
      EXPECT_EQ(hits[i].prim, one.prim) << what << " batch " << k << " lane " << i;
      EXPECT_EQ(std::memcmp(&hits[i], &one, sizeof one), 0) << what << " batch " << k << " lane " << i;
      EXPECT_EQ(bool(occluded >> i & 1), small.occluded(rl.ray(i))) << what << " batch " << k << " lane " << i;
    }
  }
}

}  // namespace

TEST(SmallAccel, AgreesWithThePortableBVHOnEveryBuiltInScene) {
  REQUIRE_AVX2();
  for (const auto& entry : builtin_scenes()) {
    auto sc = Scene::build(builtin_scene(entry.first));
    const SceneView& v = sc->view();
    ASSERT_LE(v.num_triangles, SmallAccel::kMaxTriangles) << entry.first;
    SmallAccel small(v);
    expect_agreement(v, small, entry.first.c_str());
    // What CpuAccel chose for it, and the scene's own choice.
    EXPECT_EQ(sc->accel().kind(), CpuAccel::Kind::kSmall) << entry.first;
    EXPECT_EQ(sc->embree().kind(), CpuAccel::Kind::kEmbree) << entry.first;
  }
}

TEST(SmallAccel, AgreesWithThePortableBVHOnRandomTriangles) {
  REQUIRE_AVX2();
  // 1 (a block with seven unused lanes), 9, 63, 64 (eight full blocks), 127 and 128 (sixteen full blocks,
  // the most it takes) triangles, some with spheres.
  for (int n : {1, 9, 63, 64, 127, 128}) {
    Soup s = random_soup(n, uint64_t(n));
    if (n % 2) s.spheres = {Sphere{Vec3f(0.3f, -0.2f, 0.1f), 0.25f}, Sphere{Vec3f(-0.5f, 0.4f, 0.6f), 0.4f}};
    SceneView v = s.view();
    std::vector<Bounds3> pb;
    for (uint32_t t = 0; t < v.num_triangles; ++t) {
      Bounds3 b;
      for (int k = 0; k < 3; ++k) b.extend(v.positions[v.indices[3 * t + k]]);
      pb.push_back(b);
    }
    for (const Sphere& sp : s.spheres) pb.push_back(sphere_bounds(sp));
    BVH bvh = build_bvh(pb);
    v.bvh = bvh.view();
    for (const Bounds3& b : pb) v.bounds.extend(b);
    SmallAccel small(v);
    expect_agreement(v, small, ("soup of " + std::to_string(n)).c_str());
  }
}

// Of hits at equal distance (the same triangle twice), the lowest index wins, within one block of eight and
// across blocks.
TEST(SmallAccel, EqualDistancesGoToTheLowestIndex) {
  REQUIRE_AVX2();
  Soup s = random_soup(20, 9);
  const Vec3f a(-1.f, -1.f, 3.f), b(1.f, -1.f, 3.f), c(0.f, 1.f, 3.f);
  for (uint32_t i : {5u, 2u, 17u}) {  // the same triangle at indices 2, 5 (block 0) and 17 (block 2)
    for (int k = 0; k < 3; ++k) s.p[s.idx[3 * i + k]] = (k == 0 ? a : k == 1 ? b : c);
  }
  SceneView v = s.view();
  SmallAccel small(v);
  Hit h;
  ASSERT_TRUE(small.intersect(Ray{Vec3f(0.f, -0.2f, 5.f), Vec3f(0.f, 0.f, -1.f), kInf}, h));
  EXPECT_EQ(h.prim, 2u);
  EXPECT_EQ(h.t, 2.f);
}

// What no query may hit: a zero or NaN direction, hits beyond tmax or behind the origin.
TEST(SmallAccel, DegenerateRaysAndSegments) {
  REQUIRE_AVX2();
  Soup s;
  s.add(Vec3f(-1.f, -1.f, 0.f), Vec3f(1.f, -1.f, 0.f), Vec3f(0.f, 1.f, 0.f));
  SceneView v = s.view();
  SmallAccel small(v);
  Hit h;
  const Vec3f o(0.f, 0.f, 2.f);
  EXPECT_TRUE(small.intersect(Ray{o, Vec3f(0.f, 0.f, -1.f), kInf}, h));
  EXPECT_EQ(h.t, 2.f);
  EXPECT_FALSE(small.intersect(Ray{o, Vec3f(0.f, 0.f, -1.f), 1.99f}, h));   // beyond tmax
  EXPECT_FALSE(small.occluded(Ray{o, Vec3f(0.f, 0.f, -1.f), 1.99f}));
  EXPECT_FALSE(small.intersect(Ray{o, Vec3f(0.f, 0.f, 1.f), kInf}, h));     // behind the origin
  EXPECT_FALSE(small.intersect(Ray{o, Vec3f(0.f), kInf}, h));               // zero direction
  EXPECT_FALSE(h.valid());
  EXPECT_FALSE(small.occluded(Ray{o, Vec3f(0.f, std::nanf(""), -1.f), kInf}));  // NaN direction
}

TEST(CpuAccel, ChoosesTheSmallSceneTestUpTo128TrianglesAnd8Spheres) {
  static_assert(SmallAccel::kMaxTriangles == 128, "this test names the limit");
  Soup s128 = random_soup(128, 1), s129 = random_soup(129, 1), sph = random_soup(10, 2);
  for (int i = 0; i < 9; ++i) sph.spheres.push_back(Sphere{Vec3f(0.1f * float(i), 0.f, 0.f), 0.05f});
  const SceneView v128 = s128.view(), v129 = s129.view(), v9 = sph.view();
  const bool avx2 = SmallAccel::available();
  EXPECT_EQ(CpuAccel::small_suits(v128), avx2);
  EXPECT_FALSE(CpuAccel::small_suits(v129));
  EXPECT_FALSE(CpuAccel::small_suits(v9));
  EXPECT_EQ(CpuAccel(v128).kind(), avx2 ? CpuAccel::Kind::kSmall : CpuAccel::Kind::kEmbree);
  EXPECT_STREQ(CpuAccel(v128).name(), avx2 ? "small" : "embree");
  EXPECT_EQ(CpuAccel(v128, CpuAccel::Kind::kEmbree).kind(), CpuAccel::Kind::kEmbree);
  EXPECT_EQ(CpuAccel(v129).kind(), CpuAccel::Kind::kEmbree);
  EXPECT_THROW(CpuAccel(v129, CpuAccel::Kind::kSmall), std::invalid_argument);
  EXPECT_THROW(SmallAccel{v129}, std::invalid_argument);
}

// Embree's and the portable BVH's intersect8 / occluded8 (one ray at a time underneath) answer as their
// single-ray queries, bit for bit, for the lanes asked.
TEST(CpuAccel, EightRaysAtOnceThroughEmbreeAndThePortableBVH) {
  auto sc = Scene::build(builtin_scene("smallvcm-spheres"));
  const SceneView& v = sc->view();
  const CpuAccel& embree = sc->embree();
  const BVHAccel bvh{&v};
  PCG32 rng(11, 3);
  const Vec3f lo = v.bounds.lo, ext = v.bounds.diagonal();
  for (int k = 0; k < 500; ++k) {
    RayLanes rl;
    for (int i = 0; i < 8; ++i) {
      const Vec3f o = lo + Vec3f(rng.next_float() * ext.x, rng.next_float() * ext.y, rng.next_float() * ext.z);
      const Vec3f d = square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float()));
      rl.ox[i] = o.x, rl.oy[i] = o.y, rl.oz[i] = o.z;
      rl.dx[i] = d.x, rl.dy[i] = d.y, rl.dz[i] = d.z;
      rl.tmax[i] = i % 3 == 0 ? 0.3f * length(ext) : kInf;
    }
    const int mask = int(rng.next_u32() & 0xff);
    Hit he[8], hb[8];
    embree.intersect8(rl, mask, he);
    bvh.intersect8(rl, mask, hb);
    const int oe = embree.occluded8(rl, mask), ob = bvh.occluded8(rl, mask);
    for (int i = 0; i < 8; ++i) {
      if (!(mask >> i & 1)) {
        EXPECT_FALSE((oe | ob) >> i & 1);
        continue;
      }
      Hit one_e, one_b;
      EXPECT_EQ(embree.intersect(rl.ray(i), one_e), he[i].valid());
      EXPECT_EQ(bvh.intersect(rl.ray(i), one_b), hb[i].valid());
      EXPECT_EQ(std::memcmp(&he[i], &one_e, sizeof(Hit)), 0) << "batch " << k << " lane " << i;
      EXPECT_EQ(std::memcmp(&hb[i], &one_b, sizeof(Hit)), 0) << "batch " << k << " lane " << i;
      EXPECT_EQ(bool(oe >> i & 1), embree.occluded(rl.ray(i)));
      EXPECT_EQ(bool(ob >> i & 1), bvh.occluded(rl.ray(i)));
    }
  }
}
