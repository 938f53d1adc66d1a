// --max-depth in the photon mappers bounds the whole path: a photon keeps its segments from the light
// (photon.h's photon_segments), and a visible point d segments from the camera takes only photons of at most
// max_depth - d segments (photon_budget), in sppm_gather (ppm, sppm, pppm) and pm_estimate (pm). The images
// against the path tracer are tests/python/test_photon_depth.py; here the parts, exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "caustica/integrator/photon_render.h"
#include "caustica/integrator/pm.h"
#include "caustica/integrator/sppm.h"
#include "caustica/photon/hash_grid.h"
#include "caustica/photon/knn_tree.h"
#include "caustica/scene/scene.h"

using namespace caustica;

TEST(PhotonDepth, BudgetOfAVisiblePoint) {
  EXPECT_EQ(photon_budget(5, 1), 4u);
  EXPECT_EQ(photon_budget(5, 2), 3u);
  EXPECT_EQ(photon_budget(5, 5), 0u);
  EXPECT_EQ(photon_budget(5, 9), 0u);
  EXPECT_EQ(photon_budget(0xffffffffu, 100), 0xffffffffu);  // unlimited
  Photon ph;
  ph.flags = kPhotonCaustic | photon_segment_bits(7);
  EXPECT_EQ(photon_segments(ph), 7u);
  EXPECT_EQ(ph.flags & kPhotonFlagBits, uint32_t(kPhotonCaustic));
  ph.flags = photon_segment_bits(70000);
  EXPECT_EQ(photon_segments(ph), 65535u);  // saturates
}

namespace {
// A closed 2 x 4 x 6 box of Lambertian walls with albedo 0.7 emitting inwards: every segment lands on a wall.
SceneDesc closed_box() {
  SceneDesc d;
  d.name = "box";
  d.camera.position = {0, 0, 0};
  d.camera.target = {0, 0, -1};
  d.add_material("wall", make_diffuse(RGB(0.7f)));
  ShapeDesc s;
  s.type = ShapeType::kCube;
  s.flip_normals = true;
  s.emission = RGB(1.f);
  s.material = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) s.to_world.m[i][j] = (i == j) ? float(i + 1) : 0.f;
  d.shapes.push_back(s);
  return d;
}
}  // namespace

TEST(PhotonDepth, TracedPhotonsCountTheirSegments) {
  // Photons come path by path, each path's in order: the first hit has 1 segment (and is the direct one),
  // every later photon one more than the one before, none more than max_depth.
  auto sc = Scene::build(closed_box());
  const uint32_t max_depth = 6;
  auto photons = PhotonIntegrator::trace_photons(sc->view(), sc->accel(), 3, 0, 20000, max_depth, true);
  ASSERT_GT(photons.size(), 20000u);
  uint32_t prev = 0, deepest = 0;
  for (const Photon& ph : photons) {
    const uint32_t n = photon_segments(ph);
    if (ph.flags & kPhotonDirect) ASSERT_EQ(n, 1u);
    else ASSERT_EQ(n, prev + 1);
    ASSERT_LE(n, max_depth);
    deepest = std::max(deepest, n);
    prev = n;
  }
  EXPECT_EQ(deepest, max_depth);  // albedo 0.7: a sixth bounce is common
}

namespace {
// Photons of 1 to 8 segments at points around the origin on the plane z = 0, arriving from above, with
// powers 1, 2, ..., so that each subset has its own sum.
std::vector<Photon> layered_photons() {
  std::vector<Photon> out;
  for (uint32_t i = 0; i < 64; ++i) {
    Photon ph;
    const float a = 0.37f * float(i), r = 0.01f * float(i % 9);
    ph.p = Vec3f(r * std::cos(a), r * std::sin(a), 0.f);
    ph.wi = normalize(Vec3f(0.2f, -0.1f, 1.f));
    ph.power = RGB(float(i + 1), 1.f, 0.5f);
    ph.flags = photon_segment_bits(1 + i % 8) | (i % 8 == 0 ? kPhotonDirect : 0u);
    out.push_back(ph);
  }
  return out;
}

VisiblePoint diffuse_point(uint32_t depth) {
  VisiblePoint vp;
  vp.p = Vec3f(0.f);
  vp.ng = vp.ns = Vec3f(0.f, 0.f, 1.f);
  vp.wo = normalize(Vec3f(0.f, 0.3f, 1.f));
  vp.beta = RGB(1.f);
  vp.material = make_diffuse(RGB(0.5f));
  vp.valid = true;
  vp.depth = depth;
  return vp;
}
}  // namespace

TEST(PhotonDepth, GatherKeepsThePhotonsThatFit) {
  const std::vector<Photon> photons = layered_photons();
  Bounds3 b;
  b.extend(Vec3f(-1.f));
  b.extend(Vec3f(1.f));
  PhotonHashGrid grid;
  grid.build(photons, b, 0.2f);
  const PhotonGridView view = grid.view();
  const float radius = 0.1f;  // holds every photon (r <= 0.08)
  struct Case {
    uint32_t max_depth, vp_depth;
  };
  for (const Case c : {Case{6, 2}, Case{4, 3}, Case{3, 1}, Case{2, 1}, Case{0xffffffffu, 3}}) {
    const VisiblePoint vp = diffuse_point(c.vp_depth);
    const Frame frame = tangent_frame(vp.ns, vp.tangent);
    const uint32_t budget = photon_budget(c.max_depth, c.vp_depth);
    // Expected: every photon within the budget (the photons' decoded records: positions and directions
    // rounded as the grid stores them, segments exact).
    double want[3] = {0, 0, 0};
    uint32_t want_m = 0;
    view.query(vp.p, radius, [&](const Photon& ph) {
      EXPECT_GE(photon_segments(ph), 1u);
      if (photon_segments(ph) > budget) return;
      ++want_m;
      const RGB f = bsdf_eval(vp.material, frame.to_local(vp.wo), frame.to_local(ph.wi), TransportMode::kRadiance);
      for (int ch = 0; ch < 3; ++ch) want[ch] += double(f[ch]) * ph.power[ch];
    });
    uint32_t expect_count = 0;
    for (const Photon& ph : photons) expect_count += photon_segments(ph) <= budget ? 1u : 0u;
    ASSERT_EQ(want_m, expect_count);
    double phi[3];
    uint32_t M = 0;
    sppm_gather(vp, view, radius, c.max_depth, phi, M);
    EXPECT_EQ(M, expect_count) << c.max_depth << " " << c.vp_depth;
    for (int ch = 0; ch < 3; ++ch) EXPECT_DOUBLE_EQ(phi[ch], want[ch]);
  }
}

TEST(PhotonDepth, KnnEstimateSkipsDeepPhotonsButKeepsTheRadius) {
  // pm_estimate: the k nearest of all photons set the radius; those of more than `budget` segments add
  // nothing (pm.h). Checked against the cone-filtered sum written out here.
  const std::vector<Photon> photons = layered_photons();
  const KnnTreeHost tree = build_knn_tree(photons);
  const KnnTreeView view = tree.view();
  const uint32_t k = 40;
  std::vector<uint32_t> idx(k);
  std::vector<float> d2(k);
  const VisiblePoint vp = diffuse_point(1);
  const Frame frame = tangent_frame(vp.ns, vp.tangent);
  const Vec3f wo = frame.to_local(vp.wo);
  const Vec3f p(0.003f, -0.002f, 0.f);
  // The k nearest by brute force, and the k-th distance.
  std::vector<std::pair<float, uint32_t>> by_dist;
  for (uint32_t i = 0; i < photons.size(); ++i) by_dist.push_back({photon_dist2(p, photons[i].p), i});
  std::sort(by_dist.begin(), by_dist.end());
  const float r2 = by_dist[k - 1].first, r = std::sqrt(r2);
  for (uint32_t budget : {1u, 3u, 5u, 8u}) {
    RGB want(0.f);
    for (uint32_t j = 0; j < k; ++j) {
      const Photon& ph = photons[by_dist[j].second];
      if (photon_segments(ph) > budget) continue;
      const float w = 1.f - std::sqrt(by_dist[j].first) / r;
      want += bsdf_eval(vp.material, wo, frame.to_local(ph.wi)) * ph.power * w;
    }
    want = want / ((1.f - 2.f / 3.f) * kPi * r2 * 100.f);
    const RGB got = pm_estimate(view, 100, k, budget, vp.material, frame, wo, p, idx.data(), d2.data());
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(got[ch], want[ch], 1e-5f * std::max(1.f, want[ch])) << budget;
    if (budget == 1) {
      EXPECT_GT(want[0], 0.f);  // the direct photons among the nearest
    }
  }
  // Unlimited: every one of the k nearest.
  const RGB all = pm_estimate(view, 100, k, 0xffffffffu, vp.material, frame, wo, p, idx.data(), d2.data());
  const RGB eight = pm_estimate(view, 100, k, 8, vp.material, frame, wo, p, idx.data(), d2.data());
  for (int ch = 0; ch < 3; ++ch) EXPECT_EQ(all[ch], eight[ch]);
}
