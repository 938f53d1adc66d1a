// Participating media (medium/medium.h): the Henyey-Greenstein phase function is normalised and its
// sampling follows it (chi-square, chi2.h); free-flight sampling with a hero channel and the path-level
// average of the densities is unbiased in every channel, for one event and along two (Monte Carlo means
// against the closed forms, 4 standard errors); transmittance and medium transitions.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "caustica/base/rng.h"
#include "caustica/medium/medium.h"
#include "chi2.h"
#include "moments.h"

using namespace caustica;

namespace {

// Chi-square tests in this file (the Sidak correction is over these): four values of g.
constexpr int kNumChi2Tests = 4;

chi2::Options options() {
  chi2::Options o;
  o.samples = 1000000;
  o.alpha = 0.01;
  o.n_tests = kNumChi2Tests;
  return o;
}


}  // namespace

class HenyeyGreenstein : public ::testing::TestWithParam<float> {};

TEST_P(HenyeyGreenstein, SamplesFollowThePhaseFunction) {
  const float g = GetParam();
  const Vec3f wo = normalize(Vec3f(0.3f, -0.5f, 0.8f));
  PCG32 rng(17, uint64_t(1000 * (g + 2.f)));
  auto sample = [&]() {
    Vec2f u(rng.next_float(), rng.next_float());
    float pdf = 0.f;
    Vec3f wi = hg_sample(wo, g, u, &pdf);
    // The pdf it reports is the phase function of the direction it returns (relative 1e-3: float rounding
    // of cos near the peak for g = 0.9).
    EXPECT_NEAR(pdf, hg_phase(dot(wo, wi), g), 1e-3f * hg_phase(dot(wo, wi), g));
    return chi2::SampleDir{true, wi, false};
  };
  auto density = [&](Vec3f w) { return double(hg_phase(dot(wo, w), g)); };
  chi2::Result r = chi2::test_sphere(16, sample, density, options());
  // Normalised: the quadrature's integral over the sphere within 4 of its error estimates (+1e-5 for the
  // float pdf near the peak).
  EXPECT_NEAR(r.pdf_integral, 1.0, 4.0 * r.quad_error + 1e-5) << r.report;
  EXPECT_TRUE(r.passed) << r.report;
}

INSTANTIATE_TEST_SUITE_P(Medium, HenyeyGreenstein, ::testing::Values(0.f, 0.5f, -0.7f, 0.9f));

TEST(HenyeyGreenstein, ForwardMeansAlongTheRay) {
  // wo points back along the ray: g > 0 favours wi = -wo (straight on), and the mean cosine between the
  // ray's direction and wi is g.
  const float g = 0.6f;
  const Vec3f d = normalize(Vec3f(1.f, 2.f, -0.5f));
  EXPECT_GT(hg_phase(-1.f, g), hg_phase(1.f, g));
  PCG32 rng(3, 4);
  Moments m;
  for (int i = 0; i < 200000; ++i) {
    float pdf;
    Vec3f wi = hg_sample(-d, g, Vec2f(rng.next_float(), rng.next_float()), &pdf);
    m.add(dot(d, wi));
  }
  EXPECT_NEAR(m.mean(), g, 4 * m.se());
}

TEST(Medium, TransmittanceAndCrossings) {
  RGB t = medium_transmittance(RGB(0.f, 1.f, 2.f), 0.5f);
  EXPECT_FLOAT_EQ(t.x, 1.f);
  EXPECT_FLOAT_EQ(t.y, std::exp(-0.5f));
  EXPECT_FLOAT_EQ(t.z, std::exp(-1.f));
  RGB inf = medium_transmittance(RGB(0.f, 1.f, 2.f), kInf);
  EXPECT_EQ(inf.x, 1.f);
  EXPECT_EQ(inf.y, 0.f);
  EXPECT_EQ(inf.z, 0.f);
  const Vec3f ng(0.f, 0.f, 1.f);
  MediumInterface mi{3, 5, 1u};
  EXPECT_EQ(medium_after_crossing(mi, Vec3f(0.f, 0.f, -1.f), ng, 7), 3);  // against the normal: inside
  EXPECT_EQ(medium_after_crossing(mi, Vec3f(0.f, 0.f, 1.f), ng, 7), 5);   // along it: outside
  MediumInterface none{};
  EXPECT_EQ(medium_after_crossing(none, Vec3f(0.f, 0.f, -1.f), ng, 7), 7);  // no interface: keeps the medium
}

namespace {
// One path's hero channel from a uniform number, as the path tracer draws it.
int hero_of(float u) { return u < 1.f / 3.f ? 0 : (u < 2.f / 3.f ? 1 : 2); }
}  // namespace

// With the hero channel uniform and the weight f / avg(p) (medium_update_throughput from beta = r = 1):
// E[w 1{surface}] = T(t_s); E[w 1{scatter}] = sigma_s / sigma_t (1 - exp(-sigma_t t_s)); E[w 1{scatter} t]
// = sigma_s (1 - exp(-s t_s)(1 + s t_s)) / s^2 with s = sigma_t: per channel, for a finite surface and
// none, with a channel that does not scatter at all.
TEST(Medium, FreeFlightSamplingIsUnbiasedPerChannel) {
  struct Case {
    Medium m;
    float ts;
  };
  const Case cases[] = {
      {{RGB(0.1f, 0.5f, 0.5f), RGB(0.4f, 0.5f, 1.5f), 0.f}, 1.3f},
      {{RGB(0.1f, 0.5f, 0.5f), RGB(0.4f, 0.5f, 1.5f), 0.f}, kInf},
      {{RGB(0.f, 0.5f, 0.f), RGB(0.f, 0.5f, 1.f), 0.f}, 2.f},  // channel 0: no medium at all
  };
  for (const Case& k : cases) {
    PCG32 rng(11, 12);
    Moments surf[3], scat[3], scat_t[3];
    const long n = 400000;
    for (long i = 0; i < n; ++i) {
      int hero = hero_of(rng.next_float());
      MediumSample ms = sample_medium_distance(k.m, k.ts, hero, rng.next_float());
      RGB w(1.f), r(1.f);
      ASSERT_TRUE(medium_update_throughput(ms, w, r));
      EXPECT_NEAR(r.x + r.y + r.z, 3.f, 1e-5f);  // the ratios keep average 1
      for (int c = 0; c < 3; ++c) {
        surf[c].add(ms.scattered ? 0.0 : w[c]);
        scat[c].add(ms.scattered ? w[c] : 0.0);
        scat_t[c].add(ms.scattered ? w[c] * ms.t : 0.0);
      }
    }
    const RGB st = medium_sigma_t(k.m);
    for (int c = 0; c < 3; ++c) {
      const double s = st[c], ss = k.m.sigma_s[c], T = std::isinf(k.ts) ? (s > 0 ? 0.0 : 1.0) : std::exp(-s * k.ts);
      const double e_scat = s > 0 ? ss / s * (1.0 - T) : 0.0;
      const double e_scat_t = s > 0 ? ss * (1.0 - (std::isinf(k.ts) ? 0.0 : T * (1.0 + s * k.ts))) / (s * s) : 0.0;
      // 4 standard errors of each mean (+1e-9 where the estimator is exactly constant).
      EXPECT_NEAR(surf[c].mean(), T, 4 * surf[c].se() + 1e-9) << "channel " << c << " ts " << k.ts;
      EXPECT_NEAR(scat[c].mean(), e_scat, 4 * scat[c].se() + 1e-9) << "channel " << c << " ts " << k.ts;
      EXPECT_NEAR(scat_t[c].mean(), e_scat_t, 4 * scat_t[c].se() + 1e-9) << "channel " << c << " ts " << k.ts;
    }
  }
}

// Two segments of one path with one hero channel and the ratios carried from the first event to the second
// (the path-level average of the densities): E[w 1{scatter, then surface}] = sigma_s / sigma_t
// (1 - exp(-sigma_t t1)) exp(-sigma_t t2) and E[w 1{surface, surface}] = exp(-sigma_t (t1 + t2)) per
// channel; every weight at most 3 times the channel's own analog weight (here, with albedo 1 in channel 2,
// at most 3).
TEST(Medium, FreeFlightSamplingIsUnbiasedAlongAPath) {
  const Medium m{RGB(0.1f, 0.2f, 0.f), RGB(0.4f, 1.0f, 1.5f), 0.f};
  const float t1 = 0.8f, t2 = 0.6f;
  PCG32 rng(5, 6);
  Moments sc_surf[3], surf_surf[3];
  float max_w2 = 0.f;
  for (long i = 0; i < 400000; ++i) {
    int hero = hero_of(rng.next_float());
    RGB w(1.f), r(1.f);
    MediumSample a = sample_medium_distance(m, t1, hero, rng.next_float());
    ASSERT_TRUE(medium_update_throughput(a, w, r));
    MediumSample b = sample_medium_distance(m, t2, hero, rng.next_float());
    ASSERT_TRUE(medium_update_throughput(b, w, r));
    for (int c = 0; c < 3; ++c) {
      sc_surf[c].add(a.scattered && !b.scattered ? w[c] : 0.0);
      surf_surf[c].add(!a.scattered && !b.scattered ? w[c] : 0.0);
    }
    if (a.scattered && !b.scattered) max_w2 = std::max(max_w2, w[2]);
  }
  const RGB st = medium_sigma_t(m);
  for (int c = 0; c < 3; ++c) {
    const double s = st[c];
    const double e1 = m.sigma_s[c] / s * (1.0 - std::exp(-s * t1)) * std::exp(-s * t2);
    const double e2 = std::exp(-s * (t1 + t2));
    EXPECT_NEAR(sc_surf[c].mean(), e1, 4 * sc_surf[c].se()) << "channel " << c;
    EXPECT_NEAR(surf_surf[c].mean(), e2, 4 * surf_surf[c].se()) << "channel " << c;
  }
  EXPECT_LE(max_w2, 3.f + 1e-4f);
}

TEST(Medium, FreeFlightSamplingFailsWithAWrongDensity) {
  // Negative control for the test above: distances drawn as sample_medium_distance draws them (a channel
  // chosen uniformly), but divided by channel 0's density alone instead of the channels' average: channel
  // 0's scattering estimate is then biased, and the same comparison catches it.
  const Medium m{RGB(0.1f, 0.5f, 0.5f), RGB(0.4f, 0.5f, 1.5f), 0.f};
  const RGB st = medium_sigma_t(m);
  PCG32 rng(11, 12);
  Moments scat0;
  for (long i = 0; i < 400000; ++i) {
    float uc = rng.next_float(), ud = rng.next_float();
    int c = uc < 1.f / 3.f ? 0 : (uc < 2.f / 3.f ? 1 : 2);
    double t = -std::log1p(-double(ud)) / st[c];
    scat0.add(t < 1.3 ? m.sigma_s[0] * std::exp(-st[0] * t) / (st[0] * std::exp(-st[0] * t)) : 0.0);
  }
  const double e = m.sigma_s[0] / st[0] * (1.0 - std::exp(-st[0] * 1.3));
  EXPECT_GT(std::fabs(scat0.mean() - e), 4 * scat0.se());
}
