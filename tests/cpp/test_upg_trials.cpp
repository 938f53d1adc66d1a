// The two estimators of 1/P in integrator/upg.h (P: the probability that the eye's
// sampling at a vertex lands within r of a photon), against P integrated
// numerically. The photon lies on a plane that the trial rays hit; a ray lands
// when it hits the plane within r of the photon. Plain trials (the paper's) and
// cone trials (rejection inside the cone around the photon) must both have mean 1/P,
// within 4 standard errors of their own sample means; also through a medium, where a
// trial lands only if its free-flight sampling passes (ThroughAMedium).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "caustica/backend/cpu/cpu_accel.h"
#include "caustica/base/rng.h"
#include "caustica/integrator/upg.h"
#include "caustica/scene/scene.h"

using namespace caustica;

namespace {

struct TrialSetup {
  VcmPathState prev;
  Vec3f photon;
  Vec3f plane_n;   // plane through the photon
  float radius;
};

// A vertex at the origin with normal n, viewed from wo_world, material m.
TrialSetup make_setup(Material m, Vec3f n, Vec3f wo_world, Vec3f photon, Vec3f plane_n, float r, uint32_t length) {
  TrialSetup s;
  VcmPathState& st = s.prev;
  st.m = m;
  st.sh.p = Vec3f(0.f);
  st.sh.ng = st.sh.ns = n;
  st.frame = Frame(n);
  st.wo_world = normalize(wo_world);
  st.wo = st.frame.to_local(st.wo_world);
  st.p_front = offset_ray_origin(st.sh.p, st.sh.ng, st.wo_world);
  st.beta = RGB(1.f);
  st.length = length;
  s.photon = photon;
  s.plane_n = normalize(plane_n);
  s.radius = r;
  return s;
}

// Whether a ray hits the photon's plane within r of the photon.
bool lands(const TrialSetup& s, const Ray& ray) {
  float dn = dot(ray.d, s.plane_n);
  if (std::fabs(dn) < 1e-12f) return false;
  float t = dot(s.photon - ray.o, s.plane_n) / dn;
  if (!(t > 0.f)) return false;
  return length_sq(ray.o + ray.d * t - s.photon) < s.radius * s.radius;
}

// P = Int_disc p_bsdf(w(x)) q(w(x)) |cos_x| / d^2 tr(d) dA by a polar midpoint rule (double precision); tr is
// the probability of passing a medium over the distance d (none: 1).
double exact_p(const VcmParams& p, const TrialSetup& s, const std::function<double(double)>& tr = nullptr) {
  const VcmPathState& st = s.prev;
  Frame pf(s.plane_n);
  const int nr = 400, nphi = 400;
  double sum = 0.0;
  for (int i = 0; i < nr; ++i)
    for (int j = 0; j < nphi; ++j) {
      double rr = (i + 0.5) / nr * s.radius, phi = (j + 0.5) / nphi * 2.0 * M_PI;
      double dA = rr * (s.radius / nr) * (2.0 * M_PI / nphi);
      Vec3f x = s.photon + pf.to_world(Vec3f(float(rr * std::cos(phi)), float(rr * std::sin(phi)), 0.f));
      Vec3f d = x - st.p_front;
      double d2 = length_sq(d);
      Vec3f w = normalize(d);
      Vec3f wl = st.frame.to_local(w);
      double pdf = bsdf_pdf(st.m, st.wo, wl);
      if (!(pdf > 0.0)) continue;
      double q = 1.0;
      if (st.length >= p.rr_depth) {
        RGB beta = st.beta * bsdf_eval(st.m, st.wo, wl) * (std::fabs(wl.z) / float(pdf));
        q = std::min(1.f, max_component(beta) / max_component(st.beta));
      }
      sum += pdf * q * std::fabs(dot(w, s.plane_n)) / d2 * dA * (tr ? tr(std::sqrt(d2)) : 1.0);
    }
  return sum;
}

struct Stats {
  double mean, se;
  double rays_per_estimate;
};

template <typename Est>
Stats run(int n, Est&& est) {
  double s1 = 0, s2 = 0;
  uint64_t rays = 0;
  for (int i = 0; i < n; ++i) {
    uint32_t cast = 0;
    double x = est(uint64_t(i), cast);
    rays += cast;
    s1 += x;
    s2 += x * x;
  }
  double m = s1 / n;
  return {m, std::sqrt(std::max(0.0, s2 / n - m * m) / n), double(rays) / n};
}

void check(const TrialSetup& s, const VcmParams& p, int n_plain, int n_cone, bool expect_cone) {
  double inv_p = 1.0 / exact_p(p, s);
  Stats plain = run(n_plain, [&](uint64_t i, uint32_t& cast) {
    PCG32 rng(1000 + i, 7);
    return upg_inv_p_plain(p, s.prev, rng, cast, [&](const Ray& r) { return lands(s, r); });
  });
  UpgCone cone;
  bool have_cone = upg_cone(p, s.prev, s.photon, upg_pdf_bound(s.prev.m), cone);
  ASSERT_EQ(have_cone, expect_cone);
  // Plain trials: 4 standard errors of the sample mean (the geometric count's sd is ~1/P).
  EXPECT_NEAR(plain.mean, inv_p, 4.0 * plain.se) << "plain trials, exact 1/P " << inv_p;
  if (!have_cone) return;
  Stats c = run(n_cone, [&](uint64_t i, uint32_t& cast) {
    PCG32 rng(5000 + i, 9);
    return upg_inv_p_cone(p, s.prev, cone, rng, cast, [&](const Ray& r) { return lands(s, r); });
  });
  EXPECT_NEAR(c.mean, inv_p, 4.0 * c.se) << "cone trials, exact 1/P " << inv_p;
  // The point of the cone: far fewer rays per estimate than plain trials (their expected
  // counts are Omega M / P against 1/P; with these setups Omega M < 0.05).
  EXPECT_LT(c.rays_per_estimate * 10.0, plain.rays_per_estimate);
  EXPECT_GT(c.se, 0.0);  // the cone estimate is random, not a constant
}

VcmParams params(float r) {
  VcmParams p;
  p.mode = VcmMode::kUpg;
  p.rr_depth = 5;
  p.radius = r;
  return p;
}

}  // namespace

TEST(UpgTrials, DiffuseFacingPlane) {
  Material m;
  m.type = MaterialType::kDiffuse;
  m.diffuse = RGB(0.5f);
  TrialSetup s = make_setup(m, Vec3f(0, 0, 1), Vec3f(0.2f, 0.1f, 1.f), Vec3f(0.3f, 0.2f, 1.f), Vec3f(0, 0, -1), 0.1f, 1);
  check(s, params(0.1f), 20000, 20000, true);
}

// Russian roulette at the vertex (length >= rr_depth, albedo 0.5: survival 1/2 doubles 1/P),
// an oblique plane and a tilted normal.
TEST(UpgTrials, DiffuseObliqueWithRoulette) {
  Material m;
  m.type = MaterialType::kDiffuse;
  m.diffuse = RGB(0.5f, 0.3f, 0.2f);
  TrialSetup s = make_setup(m, normalize(Vec3f(0.2f, 0, 1)), Vec3f(0, 0.3f, 1.f), Vec3f(-0.4f, 0.5f, 0.8f),
                       Vec3f(0.3f, -1.f, -0.5f), 0.08f, 6);
  check(s, params(0.08f), 20000, 20000, true);
}

// SmallVCM's glossy Phong: the density varies across the cone; the bound is global.
TEST(UpgTrials, PhongGlossy) {
  Material m;
  m.type = MaterialType::kPhong;
  m.diffuse = RGB(0.2f);
  m.specular = RGB(0.6f);
  m.exponent = 10.f;
  TrialSetup s = make_setup(m, Vec3f(0, 0, 1), Vec3f(-0.5f, 0.f, 1.f), Vec3f(0.45f, 0.05f, 1.f), Vec3f(0, 0, -1), 0.1f, 1);
  check(s, params(0.1f), 20000, 20000, true);
}

// A material without a bound (rough conductor) has no cone: plain trials only.
TEST(UpgTrials, NoBoundMeansPlainTrials) {
  Material m;
  m.type = MaterialType::kRoughConductor;
  m.alpha_x = m.alpha_y = 0.3f;
  m.flags = kConductorTint;
  m.specular = RGB(0.9f);
  TrialSetup s = make_setup(m, Vec3f(0, 0, 1), Vec3f(-0.3f, 0.f, 1.f), Vec3f(0.3f, 0.f, 1.f), Vec3f(0, 0, -1), 0.1f, 1);
  check(s, params(0.1f), 20000, 0, false);
}

// Trials through a medium (upg.h, participating media): the photon's plane is a diffuse rectangle in a
// homogeneous medium that fills the scene (the camera's; no boundary). A trial lands only when its free-flight
// sampling also passes the medium up to the plane (upg_trial_reaches), so P gains the pass probability in its
// integrand: T_hero(d) = exp(-sigma_t,hero d) with the subpath's hero channel, d from the ray's origin, and
// where the subpath has drawn no hero yet, the mean of the three channels' (each trial draws one, as the eye's
// continuation would). Plain and cone trials against that P, 4 standard errors as above; the channels'
// answers differ by a factor of 3 or more, so a trial that ignored the medium, or used another channel, fails.
TEST(UpgTrials, ThroughAMedium) {
  SceneDesc d;
  d.name = "upg-medium";
  d.camera.position = {0, 0, 3};
  d.camera.target = {0, 0, 0};
  Medium fog;
  fog.sigma_a = RGB(0.05f);
  fog.sigma_s = RGB(0.25f, 0.5f, 1.f);
  d.media.push_back(fog);
  d.medium_names.push_back("fog");
  d.camera.medium = 0;
  ShapeDesc plane;
  plane.type = ShapeType::kRectangle;
  plane.material = d.add_material("wall", make_diffuse(RGB(0.5f)));
  for (int i = 0; i < 2; ++i) plane.to_world.m[i][i] = 3.f;  // [-3, 3]^2 at z = -1.5, facing +z
  plane.to_world.m[2][3] = -1.5f;
  d.shapes.push_back(plane);
  auto sc = Scene::build(d);
  const SceneView& v = sc->view();
  ASSERT_TRUE(scene_has_media(v));

  Material m;
  m.type = MaterialType::kDiffuse;
  m.diffuse = RGB(0.5f);
  TrialSetup s = make_setup(m, Vec3f(0, 0, -1), Vec3f(0.2f, 0.1f, -1.f), Vec3f(0.3f, -0.2f, -1.5f),
                            Vec3f(0, 0, 1), 0.15f, 1);
  s.prev.medium = 0;
  s.prev.sh.prim = 0;  // the vertex's surface: one without a medium interface (the medium stays the same)
  const VcmParams p = params(0.15f);
  const RGB sigma_t = fog.sigma_a + fog.sigma_s;
  UpgCone cone;
  ASSERT_TRUE(upg_cone(p, s.prev, s.photon, upg_pdf_bound(m), cone));
  double inv_ps[4];
  int k = 0;
  for (int hero : {0, 1, 2, -1}) {
    s.prev.hero = hero;
    const double inv_p = 1.0 / exact_p(p, s, [&](double dist) {
      if (hero >= 0) return std::exp(-double(sigma_t[hero]) * dist);
      double t = 0.0;
      for (int c = 0; c < 3; ++c) t += std::exp(-double(sigma_t[c]) * dist) / 3.0;
      return t;
    });
    inv_ps[k++] = inv_p;
    auto reaches = [&](PCG32& rng, uint32_t& rays) {
      return [&](const Ray& r) { return upg_trial_reaches(v, p, s.prev, r, s.photon, rng, sc->accel(), rays); };
    };
    Stats plain = run(3000, [&](uint64_t i, uint32_t& cast) {
      PCG32 rng(7000 + i, 11);
      uint32_t rays = 0;
      return upg_inv_p_plain(p, s.prev, rng, cast, reaches(rng, rays));
    });
    EXPECT_NEAR(plain.mean, inv_p, 4.0 * plain.se) << "plain trials, hero " << hero << ", exact 1/P " << inv_p;
    Stats c = run(6000, [&](uint64_t i, uint32_t& cast) {
      PCG32 rng(9000 + i, 13);
      uint32_t rays = 0;
      return upg_inv_p_cone(p, s.prev, cone, rng, cast, reaches(rng, rays));
    });
    EXPECT_NEAR(c.mean, inv_p, 4.0 * c.se) << "cone trials, hero " << hero << ", exact 1/P " << inv_p;
  }
  EXPECT_GT(inv_ps[2], 3.0 * inv_ps[0]);  // the channels' answers are far apart
}
