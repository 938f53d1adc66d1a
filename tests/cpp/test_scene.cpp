// Scene-level checks: the power-proportional light sampler, the two
// accelerators against each other, and sphere intersection from inside/outside.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "caustica/backend/cpu/cpu_accel.h"
#include "chi2.h"
#include "caustica/base/rng.h"
#include "caustica/base/sampling.h"
#include "caustica/geometry/shapes.h"
#include "caustica/scene/builtin/builtin.h"
#include "caustica/scene/intersect.h"
#include "caustica/scene/scene.h"

using namespace caustica;

namespace {
// Lights of very different powers: cornell's two light triangles and point
// lights of intensities 1, 4, ..., 81 (11 lights).
std::shared_ptr<Scene> cornell_with_unequal_lights() {
  SceneDesc d = builtin_scene("cornell");
  for (int i = 1; i <= 9; ++i) {
    Light l;
    l.type = LightType::kPoint;
    l.L = RGB(float(i * i));
    d.lights.push_back(l);
  }
  return Scene::build(d);
}
}  // namespace

TEST(LightSampler, SelectsInProportionToPower) {
  auto sc = cornell_with_unequal_lights();
  const SceneView& v = sc->view();
  std::vector<double> power(v.num_lights);
  double total = 0;
  for (uint32_t i = 0; i < v.num_lights; ++i) total += power[i] = light_power(v, v.lights[i]);
  const int n = 2000000;
  std::vector<int> count(v.num_lights, 0);
  PCG32 rng(7, 11);
  for (int k = 0; k < n; ++k) {
    float pmf;
    uint32_t l = v.light_sampler.sample(rng.next_float(), pmf);
    ASSERT_LT(l, v.num_lights);
    ASSERT_NEAR(pmf, power[l] / total, 1e-6);  // the returned pmf is the light's power share
    count[l]++;
  }
  // Pearson chi-square over the lights (expected counts all > 5): 11 lights, 10
  // degrees of freedom; the 0.999 quantile is 29.59, so a correct sampler fails 1 in 1000.
  double chi2 = 0;
  for (uint32_t i = 0; i < v.num_lights; ++i) {
    double e = n * power[i] / total;
    ASSERT_GT(e, 5.0);
    chi2 += (count[i] - e) * (count[i] - e) / e;
  }
  EXPECT_EQ(v.num_lights, 11u);
  EXPECT_LT(chi2, 29.59);
}

TEST(LightSampler, SampleReuseChoosesAsSampleAndLeavesAUniformNumber) {
  // sample_reuse(u) picks the light sample(u.x) picks, leaves u.y alone, and
  // replaces u.x by a number that, given the light, is uniform on [0, 1): the
  // joint histogram of (light, remapped u.x in 16 bins) must expect n * pmf / 16
  // per cell. Lights of unequal powers make the alias table split buckets, so
  // both remapping branches (own part, alias part) are exercised.
  auto sc = cornell_with_unequal_lights();
  const SceneView& v = sc->view();
  const int bins = 16, n = 2000000;
  std::vector<double> count(size_t(v.num_lights) * bins, 0.0);
  PCG32 rng(5, 13);
  for (int k = 0; k < n; ++k) {
    Vec2f u(rng.next_float(), rng.next_float());
    float pmf_a, pmf_b;
    uint32_t a = v.light_sampler.sample(u.x, pmf_a);
    Vec2f w = u;
    uint32_t b = v.light_sampler.sample_reuse(w, pmf_b);
    ASSERT_EQ(a, b) << "u.x = " << u.x;
    ASSERT_EQ(pmf_a, pmf_b);
    ASSERT_EQ(w.y, u.y);
    ASSERT_GE(w.x, 0.f);
    ASSERT_LT(w.x, 1.f);
    count[size_t(b) * bins + std::min(bins - 1, int(w.x * bins))] += 1.0;
  }
  // Ends of the unit interval map into it too.
  for (float x : {0.f, kOneMinusEpsilon}) {
    Vec2f w(x, 0.5f);
    float pmf;
    ASSERT_LT(v.light_sampler.sample_reuse(w, pmf), v.num_lights);
    EXPECT_GE(w.x, 0.f);
    EXPECT_LT(w.x, 1.f);
  }
  // Pearson chi-square over all 11 x 16 cells (each expects >= 5): 175 degrees
  // of freedom; rejected below p = 1e-3, so a correct remapping fails 1 in 1000.
  double total = 0, stat = 0;
  for (uint32_t i = 0; i < v.num_lights; ++i) total += light_power(v, v.lights[i]);
  for (uint32_t i = 0; i < v.num_lights; ++i)
    for (int j = 0; j < bins; ++j) {
      double e = n * light_power(v, v.lights[i]) / total / bins;
      ASSERT_GT(e, 5.0);
      double c = count[size_t(i) * bins + j];
      stat += (c - e) * (c - e) / e;
    }
  double p = chi2::chi2_survival(stat, int(v.num_lights) * bins - 1);
  EXPECT_GT(p, 1e-3) << "chi2 = " << stat;
}

TEST(Accelerators, EmbreeAndPortableBVHAgree) {
  // Random rays from inside the scene bounds in every built-in scene: both
  // accelerators find the closest hit at the same distance and agree on
  // occlusion. Where they name different primitives (coplanar faces such as the
  // small box's bottom on the cornell floor, or shared edges), the primitive
  // Embree names must itself be hit at that distance: a tie, not an error.
  for (const auto& entry : builtin_scenes()) {
    auto sc = Scene::build(builtin_scene(entry.first));
    const SceneView& v = sc->view();
    BVHAccel bvh{&v};
    PCG32 rng(3, 5);
    int mismatches = 0, hits = 0;
    const int n = 20000;
    for (int k = 0; k < n; ++k) {
      Vec3f lo = v.bounds.lo, ext = v.bounds.diagonal();
      Ray r;
      r.o = lo + Vec3f(rng.next_float() * ext.x, rng.next_float() * ext.y, rng.next_float() * ext.z);
      r.d = square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float()));
      r.tmax = kInf;
      Hit he, hb;
      bool a = sc->embree().intersect(r, he);
      bool b = bvh.intersect(r, hb);
      ASSERT_EQ(a, b) << entry.first << " ray " << k;
      if (!a) continue;
      ++hits;
      EXPECT_NEAR(he.t, hb.t, 1e-4f * std::max(1.f, he.t)) << entry.first;
      if (he.prim != hb.prim) {
        ++mismatches;
        Hit single;
        Ray rr = r;
        ASSERT_TRUE((PrimIntersector{&v, &single}(he.prim, rr))) << entry.first;
        EXPECT_NEAR(single.t, hb.t, 1e-4f * std::max(1.f, hb.t)) << entry.first;
      }
      // Occlusion up to just before and just after the hit. Float hit distances carry an absolute error of
      // a few ulps of the coordinates (the scene is of size ~1-5), so the margins are 0.1% plus 1e-5.
      const float slack = 1e-5f * std::max(1.f, length(ext));
      Ray s = r;
      if (he.t > 2.f * slack) {
        s.tmax = he.t * 0.999f - slack;
        EXPECT_EQ(sc->embree().occluded(s), bvh.occluded(s));
      }
      s.tmax = he.t * 1.001f + slack;
      EXPECT_TRUE(sc->embree().occluded(s));
      EXPECT_TRUE(bvh.occluded(s)) << entry.first << " t " << he.t << " bvh t " << hb.t;
    }
    EXPECT_GT(hits, n / 2) << entry.first;
    EXPECT_LT(mismatches, n / 100) << entry.first;  // ties are rare
  }
}

TEST(Sphere, IntersectsFromOutsideInsideAndSurface) {
  Sphere s{{1.f, 2.f, 3.f}, 2.f};
  float t;
  Ray r{{1.f, 2.f, -7.f}, {0.f, 0.f, 1.f}, kInf};
  ASSERT_TRUE(intersect_sphere(r, s, t));
  EXPECT_NEAR(t, 8.f, 1e-5f);  // near side
  r.o = {1.f, 2.f, 3.f};
  ASSERT_TRUE(intersect_sphere(r, s, t));
  EXPECT_NEAR(t, 2.f, 1e-6f);  // from the centre
  r.o = {1.f, 2.f, 5.f};       // on the surface, leaving: no hit
  EXPECT_FALSE(intersect_sphere(r, s, t));
  r.d = {0.f, 0.f, -1.f};      // on the surface, entering: the far side
  ASSERT_TRUE(intersect_sphere(r, s, t));
  EXPECT_NEAR(t, 4.f, 1e-5f);
  r.tmax = 3.f;                // beyond tmax
  EXPECT_FALSE(intersect_sphere(r, s, t));
  // Far away and nearly tangent: the precise quadratic keeps the hit.
  Ray far{{1.f + 1.999f, 2.f, -1e4f}, {0.f, 0.f, 1.f}, kInf};
  ASSERT_TRUE(intersect_sphere(far, s, t));
  Vec3f p = far.o + far.d * t;
  EXPECT_NEAR(length(p - s.center), 2.f, 1e-3f);
}

TEST(SceneBuild, SkipsBrokenPrimitivesWithCountedWarnings) {
  // Whatever a loader lets through, Scene::build drops what cannot be hit or
  // sampled and says how many (the fuzzer found NaN centroids reaching the BVH binning).
  SceneDesc d;
  d.name = "broken";
  d.add_material("m", make_diffuse(RGB(0.5f)));
  MeshDesc m;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {nan, 0, 0}, {2, 0, 0}};
  m.indices = {0, 1, 2,   // fine
               0, 1, 3,   // NaN vertex
               0, 1, 4,   // collinear: zero area
               0, 1, 9};  // index out of range
  d.meshes.push_back(m);
  ShapeDesc s;
  s.mesh = 0;
  s.emission = RGB(1.f);  // the broken ones must not become lights either
  d.shapes.push_back(s);
  ShapeDesc sp;
  sp.type = ShapeType::kSphere;
  sp.radius = 0.f;
  d.shapes.push_back(sp);
  auto sc = Scene::build(d);
  EXPECT_EQ(sc->view().num_triangles, 1u);
  EXPECT_EQ(sc->view().num_spheres, 0u);
  EXPECT_EQ(sc->view().num_lights, 1u);
  const std::vector<std::string> expected = {
      "scene 'broken': skipped 1 triangles with vertex indices out of range",
      "scene 'broken': skipped 1 triangles with non-finite coordinates",
      "scene 'broken': skipped 1 degenerate (zero-area) triangles",
      "scene 'broken': skipped 1 spheres with a non-finite centre or a radius that is not positive"};
  EXPECT_EQ(sc->desc().warnings, expected);
}

// A spot light's power is its intensity integrated over the sphere: 2 pi L times the integral of spot_falloff
// over cos(theta), for pbrt's smoothstep band and Mitsuba's linear-in-angle band (the light sampler and the
// photon emission pick lights by power). A midpoint rule in theta with 200000 steps is exact to ~1e-9.
TEST(Scene, SpotLightPowerIsTheIntegralOfItsFalloff) {
  SceneView v;
  for (uint32_t linear : {0u, 1u})
    for (auto [inner, outer] : {std::pair{10.f, 30.f}, std::pair{0.f, 60.f}, std::pair{45.f, 45.5f}, std::pair{20.f, 20.f}}) {
      Light l;
      l.type = LightType::kSpot;
      l.L = RGB(2.f);
      l.cos_falloff_start = std::cos(inner * kPi / 180.f);
      l.cos_total = std::cos(outer * kPi / 180.f);
      l.spot_linear_angle = linear;
      const int n = 200000;
      double sum = 0.0, dt = kPi / n;
      for (int i = 0; i < n; ++i) {
        double t = (i + 0.5) * dt;
        sum += spot_falloff(l, float(std::cos(t))) * std::sin(t) * dt;
      }
      EXPECT_NEAR(light_power(v, l), 2.0 * kPi * luminance(l.L) * sum, 2e-4 * light_power(v, l))
          << "linear " << linear << ", cone " << inner << " to " << outer;
    }
}
