// Photon tracing conserves power: inside a closed box whose inward faces emit
// Le and reflect with Lambert albedo a, every emitted photon hits a wall, so the
// first-hit photons carry the emitted power Phi = pi Le A exactly, and the
// later ones Phi (a + a^2 + ...) = Phi a / (1 - a) in expectation.
#include <gtest/gtest.h>

#include <cmath>

#include "caustica/integrator/photon_render.h"
#include <tbb/task_arena.h>

#include "caustica/scene/scene.h"

using namespace caustica;

namespace {
SceneDesc closed_box(float albedo, float Le) {
  SceneDesc d;
  d.name = "box";
  d.camera.position = {0, 0, 0};
  d.camera.target = {0, 0, -1};
  d.add_material("wall", make_diffuse(RGB(albedo)));
  ShapeDesc s;
  s.type = ShapeType::kCube;
  s.flip_normals = true;  // faces point inwards
  s.emission = RGB(Le);
  s.material = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) s.to_world.m[i][j] = (i == j) ? float(i + 1) : 0.f;  // 2 x 4 x 6 box
  d.shapes.push_back(s);
  return d;
}
}  // namespace

TEST(PhotonTrace, ConservesPower) {
  const float a = 0.6f, Le = 2.f;
  auto sc = Scene::build(closed_box(a, Le));
  const double area = 2 * (2 * 4 + 4 * 6 + 2 * 6);
  const double phi = kPi * Le * area;
  const uint64_t n = 200000;
  auto photons = PhotonIntegrator::trace_photons(sc->view(), sc->accel(), 1, 0, n, 0xffffffffu, true);
  double direct = 0, indirect = 0, indirect2 = 0;
  uint64_t ndirect = 0;
  // Indirect power per photon path: sum of its non-direct photons. Paths are
  // independent; their per-path sums have a sample variance giving the standard error.
  std::vector<double> per_path;
  for (const Photon& p : photons) {
    if (p.flags & kPhotonDirect) {
      ++ndirect;
      direct += p.power.x;
      per_path.push_back(0.0);
    } else {
      per_path.back() += p.power.x;
    }
    EXPECT_FALSE(p.flags & kPhotonCaustic);  // no specular surface here
  }
  EXPECT_EQ(ndirect, n);  // a closed box: every photon lands
  EXPECT_NEAR(direct / n, phi, 1e-4 * phi);  // each first-hit photon carries Phi exactly (float sums)
  for (double v : per_path) {
    indirect += v;
    indirect2 += v * v;
  }
  double mean = indirect / n, var = indirect2 / n - mean * mean, se = std::sqrt(var / n);
  double expected = phi * a / (1 - a);
  EXPECT_NEAR(mean, expected, 4 * se) << "se " << se;  // 4 standard errors
}

TEST(PhotonTrace, DeterministicAcrossThreadCounts) {
  auto sc = Scene::build(closed_box(0.5f, 1.f));
  auto a = PhotonIntegrator::trace_photons(sc->view(), sc->accel(), 7, 3, 50000, 0xffffffffu, true);
  std::vector<Photon> b;
  {
    tbb::task_arena one(1);
    one.execute([&] { b = PhotonIntegrator::trace_photons(sc->view(), sc->accel(), 7, 3, 50000, 0xffffffffu, true); });
  }
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].p.x, b[i].p.x);
    ASSERT_EQ(a[i].power.y, b[i].power.y);
  }
}

namespace {
// Mean and standard error of the first-hit power per photon path (green channel).
void direct_power(const SceneDesc& d, uint64_t n, double& mean, double& se) {
  auto sc = Scene::build(d);
  auto photons = PhotonIntegrator::trace_photons(sc->view(), sc->accel(), 5, 0, n, 1, true);
  double s = 0, s2 = 0;
  for (const Photon& p : photons) {  // max_depth 1: only first hits, at most one per path
    s += p.power.y;
    s2 += double(p.power.y) * p.power.y;
  }
  mean = s / double(n);
  se = std::sqrt(std::max(0.0, s2 / double(n) - mean * mean) / double(n));
}
SceneDesc box_with(const Light& l, bool inside) {
  SceneDesc d = closed_box(0.5f, 0.f);
  d.shapes[0].flip_normals = inside;
  d.lights.push_back(l);
  return d;
}
}  // namespace

TEST(PhotonEmission, EveryLightTypeDeliversItsPower) {
  const double A = 2 * (2 * 4 + 4 * 6 + 2 * 6);  // the 2 x 4 x 6 box
  double m, se;
  Light pt;
  pt.type = LightType::kPoint;
  pt.p = {0.1f, -0.3f, 0.5f};
  pt.L = RGB(3.f);
  direct_power(box_with(pt, true), 100000, m, se);
  EXPECT_NEAR(m, 4 * kPi * 3.0, 1e-4 * 4 * kPi * 3.0);  // every photon lands: exactly 4 pi I

  Light spot = pt;
  spot.type = LightType::kSpot;
  spot.dir = normalize(Vec3f(0.3f, 0.f, -1.f));
  spot.cos_total = std::cos(40.f * kPi / 180.f);
  spot.cos_falloff_start = std::cos(25.f * kPi / 180.f);
  double integral = 0;  // 2 pi I int_{cos_total}^1 falloff(c) dc, midpoint rule (error < 1e-7)
  const int steps = 100000;
  for (int i = 0; i < steps; ++i) {
    double c = spot.cos_total + (1 - spot.cos_total) * (i + 0.5) / steps;
    integral += spot_falloff(spot, float(c)) * (1 - spot.cos_total) / steps;
  }
  direct_power(box_with(spot, true), 200000, m, se);
  EXPECT_NEAR(m, 2 * kPi * 3.0 * integral, 4 * se + 1e-4 * m);  // 4 standard errors

  Light sun;
  sun.type = LightType::kDirectional;
  sun.dir = normalize(Vec3f(1.f, -2.f, -3.f));
  sun.L = RGB(2.f);
  // Projected area of the box along the beam: sum over faces of A_f |n_f . d| / 2.
  Vec3f dd = sun.dir;
  double proj = 24 * std::fabs(dd.x) + 12 * std::fabs(dd.y) + 8 * std::fabs(dd.z);
  direct_power(box_with(sun, false), 200000, m, se);
  EXPECT_NEAR(m, 2.0 * proj, 4 * se) << se;  // E x projected area, 4 standard errors

  Light env;
  env.type = LightType::kEnvironment;
  env.L = RGB(0.5f);
  // Each point of a convex surface receives E = pi L from its open hemisphere.
  direct_power(box_with(env, false), 400000, m, se);
  EXPECT_NEAR(m, kPi * 0.5 * A, 4 * se) << se;
}

// Volumetric photon tracing (photon/trace.h): a point light of power Phi = 4 pi I at the centre of a null
// sphere of optical radius 40 filled with a grey medium of albedo a. Every photon path starts in the medium
// (locate_medium finds it by the sphere), and practically every one scatters (escape without a collision:
// exp(-40)); the free-flight weight makes the first event's photon carry Phi a exactly, and the events after
// it Phi (a^2 + a^3 + ...) = Phi a^2 / (1 - a) in expectation. Photons are volume photons only (no surface
// is hit before the boundary, which is crossed, not stored at).
TEST(PhotonTrace, VolumePhotonsCarryTheScatteredPower) {
  const float a = 0.6f, I = 3.f, sigma_t = 2.f;
  SceneDesc d;
  d.name = "fog-ball";
  d.camera.position = {0, 0, 0};
  d.camera.target = {0, 0, -1};
  Medium m;
  m.sigma_s = RGB(a * sigma_t);
  m.sigma_a = RGB((1.f - a) * sigma_t);
  m.g = 0.5f;
  d.media.push_back(m);
  d.medium_names.push_back("fog");
  d.camera.medium = 0;
  int null_material = d.add_material("boundary", Material());
  d.materials[size_t(null_material)].type = MaterialType::kNull;
  ShapeDesc s;
  s.type = ShapeType::kSphere;
  s.radius = 20.f;
  s.material = null_material;
  s.medium_interface = true;
  s.interior = 0;
  d.shapes.push_back(s);
  Light l;
  l.type = LightType::kPoint;
  l.p = Vec3f(0.3f, -0.2f, 0.1f);
  l.L = RGB(I);
  d.lights.push_back(l);
  auto sc = Scene::build(d);
  const double phi = 4.0 * kPi * I;
  const uint64_t n = 100000;
  auto photons = PhotonIntegrator::trace_photons(sc->view(), sc->accel(), 3, 0, n, 0xffffffffu, true);
  std::vector<double> per_path;
  uint64_t ndirect = 0;
  for (const Photon& p : photons) {
    ASSERT_TRUE(p.flags & kPhotonVolume);
    ASSERT_LT(length(p.p), 20.f);
    if (p.flags & kPhotonDirect) {
      ++ndirect;
      EXPECT_NEAR(p.power.x, phi * a, 1e-4 * phi);  // exactly Phi a (float rounding)
      per_path.push_back(0.0);
    } else {
      per_path.back() += p.power.x;
    }
  }
  EXPECT_EQ(ndirect, n);
  double sum = 0, sum2 = 0;
  for (double v : per_path) {
    sum += v;
    sum2 += v * v;
  }
  const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
  EXPECT_NEAR(mean, phi * a * a / (1 - a), 4 * se) << "se " << se;  // 4 standard errors
}
