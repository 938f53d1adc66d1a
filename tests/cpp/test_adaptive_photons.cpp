// Adaptive photon tracing's Markov chains (photon/adaptive.h, Hachisuka & Jensen 2011), on toy targets
// with known answers: the mutation keeps the uniform density and is symmetric; a chain's states follow
// V / |V| (chi-square, independent chains), including coordinates a state consumed lazily; the pass
// estimator (n_vis / S) x (mean of the deposits) is unbiased; the mutation size moves toward the target
// acceptance; V(u)'s test tells volume photons from surface photons. The renderer-level tests are in
// tests/python/test_adaptive_photons.py.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "caustica/integrator/adaptive_photons.h"
#include "caustica/photon/adaptive.h"
#include "caustica/photon/hash_grid.h"
#include "chi2.h"

using namespace caustica;

namespace {

constexpr int kChi2Tests = 6;  // chi-square tests in this file (Sidak correction)

chi2::Options chi2_options(long samples) {
  chi2::Options o;
  o.samples = samples;
  o.n_tests = kChi2Tests;
  return o;
}

// Bins of [0, 1) on the x axis of a 1 x 1 grid row: equal masses 1 / bins.
std::vector<double> uniform_masses(int bins) { return std::vector<double>(size_t(bins), 1.0 / bins); }

}  // namespace

TEST(AdaptivePhotons, MutationKeepsTheUniformDensity) {
  // x uniform, x' = mutate(x): x' is uniform again for any size d (the torus kernel's stationarity). A
  // mutation that wrapped wrongly (e.g. clamped at the ends) piles mass at 0 or 1.
  for (float d : {0.01f, 0.2f, 1.f}) {
    PCG32 rng(7, uint64_t(d * 1000));
    chi2::Grid g{0.0, 1.0, 0.0, 1.0, 64, 1};
    auto sample = [&] {
      float x = rng.next_float();
      float us = rng.next_float();
      float y = pss_mutate(x, d, us, rng.next_float());
      EXPECT_TRUE(y >= 0.f && y < 1.f) << y;
      return chi2::Sample2{true, double(y), 0.5};
    };
    chi2::Result r = chi2::test_2d_masses(g, sample, uniform_masses(64), chi2_options(200000));
    EXPECT_TRUE(r.passed) << "d = " << d << ": " << r.report;
  }
}

TEST(AdaptivePhotons, MutationStepIsSymmetric) {
  // The wrapped displacement x' - x in [-1/2, 1/2): mirrored bins [a, b) and [-b, -a) have equal
  // probability (the proposal is symmetric, so the Metropolis acceptance is the target ratio alone).
  // Pearson's statistic over the pairs, (n1 - n2)^2 / (n1 + n2), is chi-square with one degree of freedom
  // per pair; fails for a sign chosen with probability 0.51 (checked).
  const int pairs = 32;
  const float d = 0.3f;
  std::vector<double> pos(pairs, 0.0), neg(pairs, 0.0);
  PCG32 rng(11, 3);
  const long n = 1000000;
  for (long s = 0; s < n; ++s) {
    float x = rng.next_float();
    float us = rng.next_float();
    float y = pss_mutate(x, d, us, rng.next_float());
    double t = double(y) - double(x);
    t -= std::floor(t + 0.5);  // into [-1/2, 1/2)
    if (t == 0.0) continue;    // steps below half a float ulp of x round to no move (in either direction)
    int b = std::min(pairs - 1, int(std::fabs(t) * 2.0 * pairs));
    (t >= 0.0 ? pos : neg)[size_t(b)] += 1.0;
  }
  double stat = 0.0;
  int dof = 0;
  for (int b = 0; b < pairs; ++b)
    if (pos[b] + neg[b] > 0.0) {
      stat += (pos[b] - neg[b]) * (pos[b] - neg[b]) / (pos[b] + neg[b]);
      ++dof;
    }
  double p = chi2::chi2_survival(stat, dof);
  EXPECT_GE(p, chi2::sidak_alpha(0.01, kChi2Tests)) << "chi2 = " << stat << ", dof = " << dof;
}

namespace {

// A toy path: x = u0, y = u1; with x >= 0.5 it also consumes z = u2 (a coordinate only some states use).
// Visible: (x, y) in A = [0.1, 0.3] x [0.2, 0.3], or (x, y) in B = [0.6, 0.65] x [0.6, 0.9] with z < 0.25.
// Under V / |V| the point (x, y) is uniform on A with mass |A| / |V| and on B with |B| / 4 / |V|.
struct Point {
  float x = 0.f, y = 0.f;
};
constexpr double kAx0 = 0.1, kAx1 = 0.3, kAy0 = 0.2, kAy1 = 0.3;
constexpr double kBx0 = 0.6, kBx1 = 0.65, kBy0 = 0.6, kBy1 = 0.9, kBz = 0.25;
constexpr double kAreaA = (kAx1 - kAx0) * (kAy1 - kAy0), kAreaB = (kBx1 - kBx0) * (kBy1 - kBy0);
constexpr double kVisible = kAreaA + kAreaB * kBz;  // |V|

bool toy_path(PssStream& s, Point& p) {
  p.x = s.next_float();
  p.y = s.next_float();
  if (p.x < 0.5f) return p.x >= kAx0 && p.x < kAx1 && p.y >= kAy0 && p.y < kAy1;
  float z = s.next_float();
  return p.x >= kBx0 && p.x < kBx1 && p.y >= kBy0 && p.y < kBy1 && z < kBz;
}

double overlap(double a0, double a1, double b0, double b1) { return std::max(0.0, std::min(a1, b1) - std::max(a0, b0)); }

}  // namespace

TEST(AdaptivePhotons, ChainStatesFollowTheVisibleDensity) {
  // Independent chains of 64 steps; the last state of each chain that started is one sample of V / |V|
  // (photon/adaptive.h: given the uniform samples' visibilities every state is so distributed). Binned on
  // a 20 x 20 grid against the exact masses (B's through the coordinate z that only B's side consumes).
  // Proposals accepted without testing V put samples where the mass is 0, a rejection by itself.
  const int chains = 40000;
  std::vector<Point> finals;
  for (float d : {0.05f, 0.5f}) {
    finals.clear();
    PrimarySample samples[2];
    Point payloads[2];
    for (int c = 0; c < chains; ++c) {
      PCG32 rng(uint64_t(c), 1234 + uint64_t(d * 100));
      ChainCounts counts;
      Point last;
      bool any = false;
      run_visibility_chain(
          rng, 64, d, samples, payloads, [](PssStream& s, Point& p) { return toy_path(s, p); },
          [&](const Point& p) {
            last = p;
            any = true;
          },
          [] { return false; }, counts);
      if (any) finals.push_back(last);
    }
    ASSERT_GT(finals.size(), size_t(chains / 2));
    chi2::Grid g{0.0, 1.0, 0.0, 1.0, 20, 20};
    std::vector<double> mass(400, 0.0);
    for (int j = 0; j < 20; ++j)
      for (int i = 0; i < 20; ++i) {
        double x0 = g.bx(i), x1 = g.bx(i + 1), y0 = g.by(j), y1 = g.by(j + 1);
        double a = overlap(x0, x1, kAx0, kAx1) * overlap(y0, y1, kAy0, kAy1);
        double b = overlap(x0, x1, kBx0, kBx1) * overlap(y0, y1, kBy0, kBy1) * kBz;
        mass[size_t(j * 20 + i)] = (a + b) / kVisible;
      }
    size_t next = 0;
    auto sample = [&] {
      const Point& p = finals[next++];
      return chi2::Sample2{true, double(p.x), double(p.y)};
    };
    chi2::Result r = chi2::test_2d_masses(g, sample, mass, chi2_options(long(finals.size())));
    EXPECT_TRUE(r.passed) << "d = " << d << ": " << r.report;
  }
}

TEST(AdaptivePhotons, PassEstimateIsUnbiased) {
  // f = V (1 + x): integral |A| (1 + 0.2) + |B| / 4 (1 + 0.625). One "pass": 4 chains of 64 steps, estimate
  // (n_vis / S) x (sum of f over the deposits) / (steps), as the integrator normalises it. The mean of 4000
  // independent passes is within 5 standard errors of the integral. Counting the steps before a chain's
  // first visible sample in S (they deposit nothing) biases it low by about half (|V| ~ 0.024: a chain
  // starts after ~42 of its 64 steps; checked: the test then fails).
  const double exact = kAreaA * (1.0 + 0.5 * (kAx0 + kAx1)) + kAreaB * kBz * (1.0 + 0.5 * (kBx0 + kBx1));
  const int passes = 4000, chains = 4;
  const uint64_t steps = 64;
  std::vector<double> est;
  PrimarySample samples[2];
  Point payloads[2];
  for (int p = 0; p < passes; ++p) {
    ChainCounts total;
    double sum = 0.0;
    for (int c = 0; c < chains; ++c) {
      PCG32 rng(uint64_t(p) * 16 + uint64_t(c), 99);
      ChainCounts counts;
      run_visibility_chain(
          rng, steps, 0.2f, samples, payloads, [](PssStream& s, Point& pt) { return toy_path(s, pt); },
          [&](const Point& pt) { sum += 1.0 + pt.x; }, [] { return false; }, counts);
      total.add(counts);
    }
    EXPECT_EQ(total.uniform, uint64_t(chains) * steps);
    est.push_back(total.deposit_scale() * sum / double(total.uniform));
  }
  double mean = 0.0, var = 0.0;
  for (double e : est) mean += e;
  mean /= passes;
  for (double e : est) var += (e - mean) * (e - mean);
  double se = std::sqrt(var / (passes - 1) / passes);
  EXPECT_NEAR(mean, exact, 5.0 * se) << "standard error " << se;
  EXPECT_LT(se, 0.02 * exact);  // the test has the power to see a 10% bias
}

TEST(AdaptivePhotons, MutationSizeMovesTowardTheTargetAcceptance) {
  // Acceptance above 0.234: larger moves (larger d); below: smaller; no proposals: unchanged; clamped to
  // [kMinMutationSize, kMaxMutationSize]; steps shrink with the pass count.
  const float d = 0.1f;
  EXPECT_GT(adapt_mutation_size(d, 0.5, 100, 0), d);
  EXPECT_LT(adapt_mutation_size(d, 0.05, 100, 0), d);
  EXPECT_EQ(adapt_mutation_size(d, 0.05, 0, 0), d);
  EXPECT_NEAR(adapt_mutation_size(d, kTargetAcceptance, 100, 3), d, 1e-7f);
  EXPECT_LT(std::fabs(adapt_mutation_size(d, 0.0, 100, 99) - d), std::fabs(adapt_mutation_size(d, 0.0, 100, 0) - d));
  EXPECT_EQ(adapt_mutation_size(kMaxMutationSize, 1.0, 100, 0), kMaxMutationSize);
  EXPECT_EQ(adapt_mutation_size(kMinMutationSize, 0.0, 100, 0), kMinMutationSize);
  // The chain count depends on the photons per pass only (not on threads): 2048 steps a chain, 1..128.
  EXPECT_EQ(adaptive_chain_count(1), 1u);
  EXPECT_EQ(adaptive_chain_count(20000), 9u);
  EXPECT_EQ(adaptive_chain_count(uint64_t(1) << 30), 128u);
}

TEST(AdaptivePhotons, PrimarySampleStreamRecordsAndMutatesLazily) {
  // Fresh numbers are recorded; a mutation of a state changes each of its coordinates by a small step for
  // a small d and hands out fresh numbers past the coordinates the state consumed; at most kPssDims are kept.
  PCG32 rng(5, 5);
  PrimarySample a, b;
  PssStream fresh;
  fresh.out = &a;
  fresh.rng = &rng;
  for (int i = 0; i < 3; ++i) fresh.next_float();
  ASSERT_EQ(a.n, 3u);
  PssStream m;
  m.out = &b;
  m.base = &a;
  m.d = 1e-4f;
  m.rng = &rng;
  for (int i = 0; i < 3; ++i) {
    float x = m.next_float();
    double t = double(x) - double(a.u[i]);
    t -= std::floor(t + 0.5);
    EXPECT_LT(std::fabs(t), 0.05) << i;
  }
  m.next_float();  // a fourth coordinate: fresh
  EXPECT_EQ(b.n, 4u);
  for (uint32_t i = 0; i < kPssDims + 10; ++i) fresh.next_float();
  EXPECT_EQ(a.n, kPssDims);
}

// V(u)'s test for one photon (integrator/adaptive_photons.h) in a scene with media: a volume photon is
// visible only to volume visible points within their volume radius (pppm's global r_v, or sppm's per point),
// a surface photon only to surface points within their radius whose BSDF passes its direction.
TEST(AdaptivePhotons, VisibilityTellsVolumeFromSurfacePhotons) {
  std::vector<VisiblePoint> vps(2);
  vps[0].p = Vec3f(0.f, 0.f, 0.f);  // a diffuse floor point facing +z, seen from above
  vps[0].ng = vps[0].ns = Vec3f(0.f, 0.f, 1.f);
  vps[0].wo = Vec3f(0.f, 0.f, 1.f);
  vps[0].beta = RGB(1.f);
  vps[0].valid = true;
  vps[1].p = Vec3f(1.f, 0.f, 0.f);  // a scattering event in fog
  vps[1].wo = Vec3f(0.f, 0.f, 1.f);
  vps[1].beta = RGB(1.f);
  vps[1].valid = vps[1].volume = true;
  vps[1].medium = 0;
  std::vector<Photon> points(2);
  points[0].p = vps[0].p;
  points[1].p = vps[1].p;
  const std::vector<uint32_t> point_vp = {0, 1};
  const Bounds3 bounds{Vec3f(-2.f), Vec3f(2.f)};
  AdaptiveVisibility visible;
  visible.set_radii(bounds, 0.1f, 0.2f);  // pppm: surface radius 0.1, volume radius 0.2
  PhotonHashGrid grid;
  grid.build(points, bounds, 2.f * visible.query_radius, false, 0, true);
  visible.points = grid.view();
  visible.point_vp = point_vp.data();
  visible.vp = vps.data();
  auto photon = [](Vec3f p, Vec3f wi, bool volume) {
    Photon ph;
    ph.p = p;
    ph.wi = wi;
    ph.power = RGB(1.f);
    ph.flags = volume ? kPhotonVolume : 0u;
    return ph;
  };
  const Vec3f up(0.f, 0.f, 1.f), down(0.f, 0.f, -1.f);
  EXPECT_TRUE(visible(photon(Vec3f(1.15f, 0.f, 0.f), down, true)));    // within r_v of the fog point
  EXPECT_FALSE(visible(photon(Vec3f(1.25f, 0.f, 0.f), down, true)));   // beyond it
  EXPECT_FALSE(visible(photon(Vec3f(0.05f, 0.f, 0.f), up, true)));     // near the floor point only
  EXPECT_TRUE(visible(photon(Vec3f(0.05f, 0.f, 0.f), up, false)));     // on the floor, from above
  EXPECT_FALSE(visible(photon(Vec3f(0.05f, 0.f, 0.f), down, false)));  // from below: the BSDF is 0
  EXPECT_FALSE(visible(photon(Vec3f(0.15f, 0.f, 0.f), up, false)));    // beyond r, within r_v
  EXPECT_FALSE(visible(photon(Vec3f(1.05f, 0.f, 0.f), up, false)));    // near the fog point only
  // sppm: each point's own volume radius.
  const std::vector<float> R = {0.1f, 0.1f}, Rv = {0.3f, 0.3f};
  visible.R = R.data();
  visible.Rv = Rv.data();
  visible.set_radii(bounds, 0.1f, 0.3f);
  grid.build(points, bounds, 2.f * visible.query_radius, false, 0, true);
  visible.points = grid.view();
  EXPECT_TRUE(visible(photon(Vec3f(1.25f, 0.f, 0.f), down, true)));
  EXPECT_FALSE(visible(photon(Vec3f(1.35f, 0.f, 0.f), down, true)));
}
