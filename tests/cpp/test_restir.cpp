// ReSTIR DI's building blocks (integrator/restir.h): the one-sample reservoir keeps each input in proportion
// to its weight (chi-square); a light candidate's contribution over its density, as restir_candidate computes
// it and as restir_contribution evaluates it again for the same light point, equals the path tracer's NEE
// estimate of the same sample (the area / solid-angle conversion); RIS and the balance-heuristic combination
// of reservoirs from other shading points (also chained, as temporal reuse chains them) give unbiased
// estimates of the unshadowed direct light (means within 5 standard errors of the exact value, taken as the
// mean of a million NEE samples); the target is zero on the far side of a sphere light, which its cone
// sampling cannot reach. The scene has every kind of light: one-sided triangle, two-sided sphere, point,
// spot, directional, environment.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "caustica/backend/cpu/cpu_accel.h"
#include "caustica/integrator/restir.h"
#include "caustica/scene/loaders/json_loader.h"
#include "caustica/scene/scene.h"
#include "chi2.h"

using namespace caustica;

namespace {

const char* kScene = R"({
  "camera": {"position": [0, 2, 5], "target": [0, 0, 0], "width": 8, "height": 8},
  "materials": {"floor": {"type": "diffuse", "reflectance": 0.7},
                "glossy": {"type": "plastic", "diffuse": [0.3, 0.5, 0.7]}},
  "shapes": [
    {"type": "rectangle", "material": "floor", "transform": {"scale": 3, "rotate": {"axis": [1, 0, 0], "angle": -90}}},
    {"type": "rectangle", "material": "glossy", "transform": {"scale": 3, "translate": [0, 1, -2]}},
    {"type": "rectangle", "material": "floor", "emission": [4, 3, 2],
     "transform": {"scale": 0.3, "rotate": {"axis": [1, 0, 0], "angle": 90}, "translate": [0.5, 2, 0]}},
    {"type": "sphere", "center": [0, 0.6, 0], "radius": 0.25, "material": "floor", "emission": [4, 4, 10],
     "emission_two_sided": true}
  ],
  "lights": [
    {"type": "point", "position": [1, 1.5, 1], "intensity": [2, 1, 1]},
    {"type": "spot", "position": [-1, 2, 1], "target": [-1, 0, 0], "intensity": 6, "cutoff_angle": 40},
    {"type": "directional", "direction": [0.3, -1, -0.2], "irradiance": [0.3, 0.3, 0.2]},
    {"type": "environment", "radiance": [0.2, 0.3, 0.5]}
  ]
})";

// Mean and standard error per channel of n independent RGB samples sample(i).
template <typename Sample>
void mean_and_se(int n, Sample sample, RGB& mean, RGB& se) {
  double sum[3] = {0, 0, 0}, sq[3] = {0, 0, 0};
  for (int i = 0; i < n; ++i) {
    RGB x = sample(i);
    const float c[3] = {x.x, x.y, x.z};
    for (int k = 0; k < 3; ++k) {
      sum[k] += c[k];
      sq[k] += double(c[k]) * c[k];
    }
  }
  float m[3], e[3];
  for (int k = 0; k < 3; ++k) {
    m[k] = float(sum[k] / n);
    e[k] = float(std::sqrt(std::max(0.0, sq[k] / n - (sum[k] / n) * (sum[k] / n)) / n));
  }
  mean = RGB(m[0], m[1], m[2]);
  se = RGB(e[0], e[1], e[2]);
}

struct Fixture {
  std::shared_ptr<Scene> scene = Scene::build(load_json_scene_text(kScene, "restir-test.json"));
  const SceneView& s = scene->view();

  // The shading point where a ray from `from` towards `to` first hits the scene.
  RestirShading point(Vec3f from, Vec3f to, RGB beta = RGB(1.f)) const {
    Ray r;
    r.o = from;
    r.d = normalize(to - from);
    r.tmax = kInf;
    Hit h;
    EXPECT_TRUE(scene->cpu_accel("auto").intersect(r, h));
    RestirVertex v;
    v.sh = make_surface_hit(s, r, h);
    v.wo = -r.d;
    v.beta = beta;
    v.depth = h.t;
    v.valid = true;
    return restir_shading(s, v);
  }

  // The unshadowed direct light at v by the path tracer's NEE (path.h's estimate without MIS and shadow ray),
  // mean and standard error over n samples.
  void nee(const RestirShading& v, int n, RGB& mean, RGB& se) const {
    PCG32 rng(3, 17);
    mean_and_se(
        n,
        [&](int) {
          Vec2f u(rng.next_float(), rng.next_float());
          float pmf;
          uint32_t li = s.light_sampler.sample_reuse(u, pmf);
          LightSample ls;
          if (!sample_light(s, s.lights[li], v.p_front, u, ls)) return RGB(0.f);
          Vec3f wi = v.frame.to_local(ls.wi);
          return v.beta * bsdf_eval(v.m, v.wo, wi) * ls.Li * (abs_cos_theta(wi) / (pmf * ls.pdf));
        },
        mean, se);
  }
};

// Mean and standard error of g_q(y) W over `trials` reservoirs made by `make`.
template <typename Make>
void reservoir_estimate(const SceneView& s, const RestirShading& q, int trials, Make make, RGB& mean, RGB& se) {
  mean_and_se(
      trials,
      [&](int t) {
        Reservoir r = make(t);
        if (!r.has_sample()) return RGB(0.f);
        Vec3f wi;
        float dist;
        return restir_contribution(s, q, r.y, wi, dist) * r.W;
      },
      mean, se);
}

// |a - b| within 5 standard errors of the difference, per channel (independent estimates).
void expect_agree(RGB a, RGB sa, RGB b, RGB sb, const char* what) {
  const float av[3] = {a.x, a.y, a.z}, bv[3] = {b.x, b.y, b.z};
  const float sav[3] = {sa.x, sa.y, sa.z}, sbv[3] = {sb.x, sb.y, sb.z};
  for (int k = 0; k < 3; ++k) {
    float se = std::sqrt(sav[k] * sav[k] + sbv[k] * sbv[k]);
    EXPECT_GT(av[k], 0.f) << what;
    EXPECT_LT(std::fabs(av[k] - bv[k]), 5.f * se) << what << " channel " << k << ": " << av[k] << " vs " << bv[k]
                                                  << " (se " << se << ")";
  }
}

}  // namespace

TEST(Restir, ReservoirKeepsEachInputInProportionToItsWeight) {
  // Eight inputs of weights 1..8 streamed through one slot: input i is kept with probability w_i / sum w.
  // Pearson chi-square, 7 degrees of freedom, rejected at p < 1e-3 (a correct reservoir fails 1 run in 1000).
  const int n = 200000, k = 8;
  std::vector<double> count(k, 0.0);
  PCG32 rng(5, 9);
  for (int t = 0; t < n; ++t) {
    Reservoir r;
    for (int i = 0; i < k; ++i) {
      LightPoint x;
      x.light = i;
      r.update(x, float(i + 1), 1.f, rng.next_float());
    }
    count[r.y.light] += 1.0;
  }
  double stat = 0.0;
  for (int i = 0; i < k; ++i) {
    double e = n * (i + 1) / 36.0;
    stat += (count[i] - e) * (count[i] - e) / e;
  }
  EXPECT_GT(chi2::chi2_survival(stat, k - 1), 1e-3) << stat;
}

TEST(Restir, CandidateOverDensityIsTheNeeEstimate) {
  // The same uniform numbers through restir_candidate (density in the light domain's measure) and through
  // path.h's light sampling (solid-angle density): g / pdf must be the same number, for every kind of light.
  Fixture f;
  const SceneView& s = f.s;
  RestirShading q = f.point(Vec3f(0.3f, 2.f, 2.f), Vec3f(-0.2f, 0.f, 0.4f));
  PCG32 rng(1, 2);
  int kinds_seen[6] = {0, 0, 0, 0, 0, 0};
  for (int t = 0; t < 20000; ++t) {
    Vec2f u(rng.next_float(), rng.next_float());
    LightPoint y;
    float pdf;
    Vec2f u2 = u;
    float pmf;
    uint32_t li = s.light_sampler.sample_reuse(u2, pmf);
    LightSample ls;
    bool nee_ok = sample_light(s, s.lights[li], q.p_front, u2, ls);
    RGB g_direct;
    bool ok = restir_candidate(s, q, false, u, y, pdf, g_direct);
    ASSERT_EQ(ok, nee_ok && ls.pdf > 0.f);
    if (!ok) continue;
    ASSERT_EQ(uint32_t(y.light), li);
    kinds_seen[int(s.lights[li].type)]++;
    Vec3f wi;
    float dist;
    RGB g = restir_contribution(s, q, y, wi, dist);
    Vec3f wl = q.frame.to_local(ls.wi);
    RGB e = bsdf_eval(q.m, q.wo, wl) * ls.Li * (abs_cos_theta(wl) / (pmf * ls.pdf));
    RGB r = g / pdf, rd = g_direct / pdf;
    const float rv[3] = {r.x, r.y, r.z}, dv[3] = {rd.x, rd.y, rd.z}, ev[3] = {e.x, e.y, e.z};
    for (int k = 0; k < 3; ++k) {
      ASSERT_NEAR(rv[k], ev[k], 2e-3f * std::fabs(ev[k]) + 1e-6f) << t << " light " << li;
      ASSERT_NEAR(dv[k], ev[k], 2e-3f * std::fabs(ev[k]) + 1e-6f) << t << " light " << li;
    }
  }
  for (int k = 0; k < 6; ++k) EXPECT_GT(kinds_seen[k], 0) << "light type " << k << " never sampled";
}

// Candidates chosen by power and by the light BVH's importance from the shading point (a source density that
// differs from point to point): the same expectation.
TEST(Restir, InitialReservoirIsUnbiased) {
  Fixture f;
  RestirShading q = f.point(Vec3f(0.3f, 2.f, 2.f), Vec3f(-0.2f, 0.f, 0.4f), RGB(0.5f, 1.f, 2.f));
  RGB ref, ref_se;
  f.nee(q, 1000000, ref, ref_se);
  for (bool bvh : {false, true}) {
    for (uint32_t M : {1u, 4u, 32u}) {
      RGB est, est_se;
      PCG32 rng(11, M);
      reservoir_estimate(f.s, q, 200000 / M, [&](int) { return restir_initial(f.s, q, M, bvh, rng); }, est, est_se);
      expect_agree(est, est_se, ref, ref_se, bvh ? "RIS, light BVH" : "RIS");
    }
  }
}

TEST(Restir, CombinedReservoirsAreUnbiased) {
  // Spatial reuse: the pixel's own reservoir and those of three other shading points - another floor point,
  // a point on the glossy wall (another normal and BSDF), and a floor point on the far side of the two-sided
  // sphere light - resampled for q with unequal confidences. Without the far-side test in
  // restir_contribution, q's target would be positive on the part of the sphere only the far neighbour can
  // sample, q's balance-heuristic weights there would not sum to one, and this estimate would fall short.
  Fixture f;
  RestirShading q = f.point(Vec3f(-0.6f, 0.3f, 0.5f), Vec3f(-0.4f, 0.f, 0.2f));
  RestirShading n1 = f.point(Vec3f(0.3f, 2.f, 2.f), Vec3f(-0.2f, 0.f, 0.4f));
  RestirShading n2 = f.point(Vec3f(1.2f, 1.5f, 2.f), Vec3f(1.f, 1.2f, -2.f), RGB(0.7f));
  RestirShading n3 = f.point(Vec3f(0.6f, 0.3f, -0.5f), Vec3f(0.4f, 0.f, -0.2f));
  ASSERT_TRUE(q.valid && n1.valid && n2.valid && n3.valid);
  // The far-side test: a point on the sphere's side facing n3 is out of q's reach.
  {
    LightPoint y;
    y.light = -1;
    for (uint32_t i = 0; i < f.s.num_lights; ++i)
      if (f.s.lights[i].type == LightType::kSphere) y.light = int32_t(i);
    ASSERT_GE(y.light, 0);
    y.n = normalize(Vec3f(1.f, 0.f, -0.7f));
    y.p = Vec3f(0.f, 0.6f, 0.f) + y.n * 0.25f;
    EXPECT_EQ(restir_target(f.s, q, y), 0.f);
    EXPECT_GT(restir_target(f.s, n3, y), 0.f);
  }
  RGB ref, ref_se;
  f.nee(q, 1000000, ref, ref_se);
  const RestirShading* vs[4] = {&q, &n1, &n2, &n3};
  // Each neighbour's candidates by power, then by the light BVH from its own point (the source densities
  // differ between the inputs; the combination weighs them by targets alone).
  for (bool bvh : {false, true}) {
    RGB est, est_se;
    PCG32 rng(21, 4);
    reservoir_estimate(f.s, q, 100000,
                       [&](int) {
                         Reservoir in[4] = {restir_initial(f.s, q, 8, bvh, rng), restir_initial(f.s, n1, 4, bvh, rng),
                                            restir_initial(f.s, n2, 16, bvh, rng), restir_initial(f.s, n3, 8, bvh, rng)};
                         float c[4] = {in[0].c, in[1].c, in[2].c, in[3].c * 3.f};
                         return restir_combine(f.s, vs, in, c, 4, rng);
                       },
                       est, est_se);
    expect_agree(est, est_se, ref, ref_se, bvh ? "spatial, light BVH" : "spatial");
  }
}

TEST(Restir, ChainedReuseIsUnbiased) {
  // Temporal reuse chains reservoirs: each step combines fresh candidates at one shading point with the
  // previous step's output from another (capped confidence), and the steps' inputs are correlated. Five
  // steps alternating between q, the glossy wall and the far-side floor point, ending at q.
  Fixture f;
  RestirShading q = f.point(Vec3f(-0.6f, 0.3f, 0.5f), Vec3f(-0.4f, 0.f, 0.2f));
  RestirShading a = f.point(Vec3f(1.2f, 1.5f, 2.f), Vec3f(1.f, 1.2f, -2.f));
  RestirShading b = f.point(Vec3f(0.6f, 0.3f, -0.5f), Vec3f(0.4f, 0.f, -0.2f));
  const RestirShading* chain[5] = {&b, &a, &b, &a, &q};
  RGB ref, ref_se, est, est_se;
  f.nee(q, 1000000, ref, ref_se);
  PCG32 rng(31, 8);
  reservoir_estimate(f.s, q, 40000,
                     [&](int) {
                       Reservoir prev;
                       const RestirShading* pv = nullptr;
                       for (const RestirShading* v : chain) {
                         Reservoir fresh = restir_initial(f.s, *v, 4, false, rng);
                         if (!pv) {
                           prev = fresh;
                         } else {
                           const RestirShading* vs[2] = {v, pv};
                           Reservoir in[2] = {fresh, prev};
                           float c[2] = {fresh.c, std::min(prev.c, 8.f)};
                           prev = restir_combine(f.s, vs, in, c, 2, rng);
                         }
                         pv = v;
                       }
                       return prev;
                     },
                     est, est_se);
  expect_agree(est, est_se, ref, ref_se, "chained");
}
