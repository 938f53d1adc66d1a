// Statistical tests of the sampling warps (base/sampling.h) and of the
// samplers (base/sampler.h).
//
// Warps: the pdf integrates to 1 over its domain (adaptive quadrature; the
// tolerance is the quadrature's own error estimate) and the samples follow the
// pdf (chi-square, chi2.h). Sobol: the Owen-scrambled, shuffled (0,2)-sequence
// gives (0,k,2)-nets in every pair of dimensions (deterministic). PCG32: the
// first two moments of its uniforms.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "caustica/base/rng.h"
#include "caustica/base/sampler.h"
#include "caustica/base/sampling.h"
#include "chi2.h"

using namespace caustica;

namespace {

// Chi-square tests in this file whose null hypothesis is true (the Sidak
// correction is over these): cosine hemisphere, uniform sphere, uniform
// hemisphere, 4 cones, concentric disk, triangle.
constexpr int kNumChi2Tests = 9;
constexpr int kRes = 16;  // sphere grid: 32 (phi) x 16 (cos theta) bins of equal solid angle

chi2::Options options() {
  chi2::Options o;
  o.samples = 1000000;
  o.alpha = 0.01;
  o.n_tests = kNumChi2Tests;
  return o;
}

// |integral - 1| <= 4 x the quadrature's error estimate + 1e-6: the estimate
// sums |Gauss(children) - Gauss(cell)| over the cells (over 255 where the
// refinement converged); 1e-6 covers the single-precision pdf values (each
// relative error <= 2^-24, so their weighted sum is within ~1e-7 of exact).
void expect_normalised(const chi2::Result& r, const char* what) {
  EXPECT_NEAR(r.pdf_integral, 1.0, 4.0 * r.quad_error + 1e-6) << what << ": " << r.report;
}

template <class Warp, class Pdf>
chi2::Result sphere_warp_test(uint64_t seed, Warp&& warp, Pdf&& pdf, chi2::Options o = options(), int res = kRes) {
  PCG32 rng(seed, 0x1234);
  auto sample = [&]() {
    float a = rng.next_float();
    float b = rng.next_float();
    return chi2::SampleDir{true, warp(Vec2f(a, b)), false};
  };
  return chi2::test_sphere(res, sample, pdf, o);
}

}  // namespace

// ---------------------------------------------------------------------------
// The chi-square machinery itself.

TEST(Chi2Helper, IncompleteGammaMatchesKnownValues) {
  // Q(1, x) = exp(-x) and Q(1/2, x) = erfc(sqrt(x)) exactly; chi-square
  // critical values (Abramowitz & Stegun Table 26.8, 5 significant digits)
  // give the tail 0.05 to about 1e-5.
  for (double x : {0.01, 0.5, 1.0, 2.0, 5.0, 30.0}) {
    EXPECT_NEAR(chi2::gamma_q(1.0, x), std::exp(-x), 1e-12 * std::exp(-x) + 1e-15) << x;
    EXPECT_NEAR(chi2::gamma_q(0.5, x), std::erfc(std::sqrt(x)), 1e-10 * std::erfc(std::sqrt(x)) + 1e-15) << x;
  }
  EXPECT_NEAR(chi2::chi2_survival(3.8415, 1), 0.05, 1e-5);
  EXPECT_NEAR(chi2::chi2_survival(18.307, 10), 0.05, 1e-5);
  EXPECT_NEAR(chi2::chi2_survival(124.342, 100), 0.05, 1e-5);
  EXPECT_NEAR(chi2::chi2_survival(6.6349, 1), 0.01, 1e-5);
  EXPECT_NEAR(chi2::chi2_survival(135.807, 100), 0.01, 1e-5);
  // Sidak: 1 - (1 - 0.01)^(1/9).
  EXPECT_NEAR(chi2::sidak_alpha(0.01, 9), 1.0 - std::pow(0.99, 1.0 / 9.0), 1e-15);
}

TEST(Chi2Helper, RejectsASlightlyWrongPdf) {
  // Negative control: cosine-weighted samples against the normalised density
  // (n + 1) / (2 pi) cos^n with n = 1.03 instead of 1. The test must reject.
  const double n = 1.03;
  auto pdf = [&](Vec3f w) { return w.z > 0.f ? float((n + 1.0) / (2.0 * chi2::kPi) * std::pow(w.z, n)) : 0.f; };
  chi2::Result r = sphere_warp_test(11, square_to_cosine_hemisphere, pdf);
  EXPECT_LT(r.p_value, r.alpha) << r.report;
}

TEST(Chi2Helper, RejectsADistortedWarp) {
  // Negative control: a uniform-sphere warp with cos theta = 1 - 2u displaced by
  // 0.01 sin(2 pi u) (at most 0.5 % of its range; the density is off by up to
  // 3 %) must be rejected.
  auto warp = [](Vec2f u) {
    float z = 1.f - 2.f * u.x + 0.01f * std::sin(2.f * kPi * u.x);
    z = clampf(z, -1.f, 1.f);
    float r = safe_sqrt(1.f - z * z), phi = 2.f * kPi * u.y;
    return Vec3f(r * std::cos(phi), r * std::sin(phi), z);
  };
  chi2::Result r = sphere_warp_test(12, warp, [](Vec3f) { return uniform_sphere_pdf(); });
  EXPECT_LT(r.p_value, r.alpha) << r.report;
}

TEST(Chi2Helper, RejectsMissingDiscreteMass) {
  // Negative control: a "mixed" sampler that returns a delta sample 3 % of the
  // time but whose continuous pdf integrates to 1: the other bin expects ~0.
  PCG32 rng(13, 0x1234);
  auto sample = [&]() {
    float c = rng.next_float(), a = rng.next_float(), b = rng.next_float();
    if (c < 0.03f) return chi2::SampleDir{true, Vec3f(0.f, 0.f, 1.f), true};
    return chi2::SampleDir{true, square_to_cosine_hemisphere(Vec2f(a, b)), false};
  };
  chi2::Result r = chi2::test_sphere(kRes, sample, cosine_hemisphere_pdf, options());
  EXPECT_LT(r.p_value, r.alpha) << r.report;
}

TEST(Chi2Helper, RejectsSamplesWherePdfIsZero) {
  // Negative control: cosine-weighted samples, one in 10^4 mirrored below the
  // horizon where the pdf is 0. The 100 stray samples exceed the 1e-5 N
  // allowance.
  PCG32 rng(14, 0x1234);
  long k = 0;
  auto sample = [&]() {
    float a = rng.next_float(), b = rng.next_float();
    Vec3f w = square_to_cosine_hemisphere(Vec2f(a, b));
    if (++k % 10000 == 0) w.z = -w.z;
    return chi2::SampleDir{true, w, false};
  };
  chi2::Result r = chi2::test_sphere(kRes, sample, cosine_hemisphere_pdf, options());
  EXPECT_EQ(r.zero_pdf_samples, 100);
  EXPECT_FALSE(r.passed) << r.report;
}

// ---------------------------------------------------------------------------
// Warps.

TEST(Warps, CosineHemisphere) {
  chi2::Result r = sphere_warp_test(1, square_to_cosine_hemisphere, cosine_hemisphere_pdf);
  expect_normalised(r, "cosine hemisphere");
  EXPECT_TRUE(r.passed) << r.report;  // p >= Sidak-corrected alpha (0.01 over the file)
}

TEST(Warps, UniformSphere) {
  chi2::Result r = sphere_warp_test(2, square_to_uniform_sphere, [](Vec3f) { return uniform_sphere_pdf(); });
  expect_normalised(r, "uniform sphere");
  EXPECT_TRUE(r.passed) << r.report;  // p >= Sidak-corrected alpha
}

TEST(Warps, UniformHemisphere) {
  chi2::Result r = sphere_warp_test(3, square_to_uniform_hemisphere,
                                    [](Vec3f w) { return w.z > 0.f ? uniform_hemisphere_pdf() : 0.f; });
  expect_normalised(r, "uniform hemisphere");
  EXPECT_TRUE(r.passed) << r.report;  // p >= Sidak-corrected alpha
}

TEST(Warps, UniformCone) {
  // From wider than a hemisphere to narrow. The cone's edge is a step of the
  // pdf; it is put on a bin edge (cos theta = -1 + 2 j / res), where the
  // Gauss-Legendre nodes, all inside the bins, integrate it exactly. The
  // narrowest cone gets a finer grid so that it spans more than one bin.
  struct Cone {
    float cos_max;
    int res;
  };
  uint64_t seed = 4;
  for (Cone c : {Cone{-0.5f, kRes}, Cone{0.25f, kRes}, Cone{0.75f, kRes}, Cone{0.9375f, 2 * kRes}}) {
    auto warp = [&](Vec2f u) { return square_to_uniform_cone(u, c.cos_max); };
    auto pdf = [&](Vec3f w) { return w.z >= c.cos_max ? uniform_cone_pdf(c.cos_max) : 0.f; };
    chi2::Result r = sphere_warp_test(seed++, warp, pdf, options(), c.res);
    expect_normalised(r, "uniform cone");
    EXPECT_TRUE(r.passed) << "cos_theta_max = " << c.cos_max << ": " << r.report;  // p >= Sidak-corrected alpha
  }
}

TEST(Warps, QuarterPiSinCosMatchesTheLibrary) {
  // Over |x| <= pi/4 the polynomials' truncation error is < 2e-9; what is left
  // is float rounding in Horner's rule (6.3e-8 measured, about one ulp of
  // values in [0.5, 1); std::sin/cos in float: 3.2e-8). Bound 1.2e-7, two such
  // ulp. Dropping sin's x^9 term would give 3.1e-7 at pi/4, a wrong sign or
  // coefficient in a lower term far more.
  double worst = 0.0;
  for (int i = -100000; i <= 100000; ++i) {
    float x = float(i) * (kPi / 4.f) / 100000.f;
    float s, c;
    sincos_quarter_pi(x, s, c);
    worst = std::max({worst, std::fabs(double(s) - std::sin(double(x))), std::fabs(double(c) - std::cos(double(x)))});
  }
  EXPECT_LT(worst, 1.2e-7);
}

TEST(Warps, ConcentricDisk) {
  // A 32 x 32 grid over the disk's bounding square [-1, 1]^2; pdf 1/pi inside.
  chi2::Grid g{-1.0, 1.0, -1.0, 1.0, 32, 32};
  PCG32 rng(5, 0x1234);
  long outside = 0;
  auto sample = [&]() {
    float a = rng.next_float();
    float b = rng.next_float();
    Vec2f p = square_to_concentric_disk(Vec2f(a, b));
    if (p.x * p.x + p.y * p.y > 1.f + 1e-6f) ++outside;  // float rounding of r cos, r sin
    return chi2::Sample2{true, p.x, p.y, false};
  };
  auto pdf = [](double x, double y) { return x * x + y * y <= 1.0 ? double(concentric_disk_pdf()) : 0.0; };
  chi2::Options o = options();
  o.quad.max_depth = 9;
  chi2::Result r = chi2::test_2d(g, sample, pdf, o);
  EXPECT_EQ(outside, 0);  // the warp maps the square onto the unit disk
  expect_normalised(r, "concentric disk");
  EXPECT_TRUE(r.passed) << r.report;  // p >= Sidak-corrected alpha
}

namespace {
// Exact area of {(x, y) in [x0, x1] x [y0, y1] : x + y <= 1}: the integrand
// clamp(1 - x - y0, 0, y1 - y0) is piecewise linear in x with kinks at
// x = 1 - y1 and x = 1 - y0, so the trapezoid rule between kinks is exact.
double area_below_antidiagonal(double x0, double x1, double y0, double y1) {
  auto h = [&](double x) { return std::clamp(1.0 - x - y0, 0.0, y1 - y0); };
  std::vector<double> xs{x0, x1};
  for (double k : {1.0 - y1, 1.0 - y0})
    if (k > x0 && k < x1) xs.push_back(k);
  std::sort(xs.begin(), xs.end());
  double a = 0.0;
  for (size_t i = 0; i + 1 < xs.size(); ++i) a += 0.5 * (h(xs[i]) + h(xs[i + 1])) * (xs[i + 1] - xs[i]);
  return a;
}
}  // namespace

TEST(Warps, UniformTriangle) {
  // Barycentrics (b1, b2) on a 24 x 24 grid over [0, 1]^2; uniform over the
  // triangle means density 2 on b1 + b2 <= 1. The antidiagonal cuts bins in
  // half, a step that quadrature only approximates, so the expected masses
  // are the exact clipped areas instead.
  chi2::Grid g{0.0, 1.0, 0.0, 1.0, 24, 24};
  PCG32 rng(6, 0x1234);
  long outside = 0;
  auto sample = [&]() {
    float a = rng.next_float();
    float b = rng.next_float();
    Vec2f bc = square_to_uniform_triangle(Vec2f(a, b));
    if (bc.x < 0.f || bc.y < 0.f || 1.f - bc.x - bc.y < -1e-6f) ++outside;
    return chi2::Sample2{true, bc.x, bc.y, false};
  };
  std::vector<double> mass(size_t(g.nx) * g.ny);
  double total = 0.0;
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i)
      total += mass[size_t(j) * g.nx + i] = 2.0 * area_below_antidiagonal(g.bx(i), g.bx(i + 1), g.by(j), g.by(j + 1));
  EXPECT_NEAR(total, 1.0, 1e-12);  // exact areas; double rounding only
  chi2::Result r = chi2::test_2d_masses(g, sample, mass, options());
  EXPECT_EQ(outside, 0);  // b0 = 1 - b1 - b2 >= 0 (up to float rounding)
  EXPECT_TRUE(r.passed) << r.report;  // p >= Sidak-corrected alpha
}

// ---------------------------------------------------------------------------
// Sobol: (0,k,2)-nets, a deterministic property.

namespace {
// Every elementary interval of area 2^-k (2^a x 2^(k-a) cells, a = 0..k)
// holds exactly one of the 2^k points.
bool is_0k2_net(const std::vector<Vec2f>& p, int k, std::string& why) {
  const size_t n = size_t(1) << k;
  std::vector<int> count(n);
  for (int a = 0; a <= k; ++a) {
    std::fill(count.begin(), count.end(), 0);
    for (const Vec2f& q : p) {
      if (!(q.x >= 0.f && q.x < 1.f && q.y >= 0.f && q.y < 1.f)) {
        why = "point outside [0,1)^2";
        return false;
      }
      // Exact: q.x has 24 mantissa bits and k <= 24.
      uint32_t cx = uint32_t(std::ldexp(double(q.x), a)), cy = uint32_t(std::ldexp(double(q.y), k - a));
      if (++count[(size_t(cx) << (k - a)) | cy] > 1) {
        why = "two points in an interval of shape 2^-" + std::to_string(a) + " x 2^-" + std::to_string(k - a);
        return false;
      }
    }
  }
  return true;
}
}  // namespace

TEST(Sobol, EveryDimensionPairIsA0k2Net) {
  const int kMaxK = 12, kPairs = 8;
  for (uint64_t seed : {0ull, 42ull, 0xdeadbeefull})
    for (uint32_t pixel : {0u, 7u, 123456u}) {
      for (int k = 0; k <= kMaxK; ++k) {
        const uint32_t n = 1u << k;
        std::vector<std::vector<Vec2f>> pts(kPairs, std::vector<Vec2f>(n));
        for (uint32_t i = 0; i < n; ++i) {
          Sampler s;
          s.start(SamplerType::kSobol, seed, pixel, i);
          for (int d = 0; d < kPairs; ++d) pts[d][i] = s.next_2d();
        }
        for (int d = 0; d < kPairs; ++d) {
          std::string why;
          EXPECT_TRUE(is_0k2_net(pts[d], k, why))
              << "seed " << seed << " pixel " << pixel << " k " << k << " pair " << d << ": " << why;
        }
      }
    }
}

TEST(Sobol, EveryDimensionIsStratified) {
  // next_1d: the first 2^k samples put exactly one point in each [j, j+1) / 2^k.
  const int kMaxK = 12, kDims = 8;
  for (uint64_t seed : {0ull, 42ull})
    for (uint32_t pixel : {0u, 99u}) {
      for (int k = 0; k <= kMaxK; ++k) {
        const uint32_t n = 1u << k;
        std::vector<std::vector<int>> count(kDims, std::vector<int>(n, 0));
        for (uint32_t i = 0; i < n; ++i) {
          Sampler s;
          s.start(SamplerType::kSobol, seed, pixel, i);
          for (int d = 0; d < kDims; ++d) {
            float x = s.next_1d();
            ASSERT_TRUE(x >= 0.f && x < 1.f);
            ++count[d][uint32_t(std::ldexp(double(x), k))];
          }
        }
        for (int d = 0; d < kDims; ++d)
          for (uint32_t j = 0; j < n; ++j)
            ASSERT_EQ(count[d][j], 1) << "seed " << seed << " pixel " << pixel << " k " << k << " dim " << d;
      }
    }
}

TEST(Sobol, FastSecondDimensionMatchesDirectionNumbers) {
  // sobol_dim1_reversed (the Pascal-matrix bit trick) must be the bit reversal
  // of the direction-number construction, for all indices below 2^20 and for
  // a million random 32-bit indices.
  for (uint32_t i = 0; i < (1u << 20); ++i)
    ASSERT_EQ(sobol_dim1_reversed(i), reverse_bits32(sobol_dim1_reference(i))) << i;
  PCG32 rng(9, 0x1234);
  for (int k = 0; k < 1000000; ++k) {
    uint32_t i = rng.next_u32();
    ASSERT_EQ(sobol_dim1_reversed(i), reverse_bits32(sobol_dim1_reference(i))) << i;
  }
}

TEST(Sobol, PixelsAreDecorrelated) {
  // Different pixels must get different scrambles: the first point of a pixel,
  // over 2^16 pixels, is itself uniform. Mean within 4 standard errors
  // (sqrt(1/12/N)) of 1/2 in both coordinates.
  const int n = 1 << 16;
  double sx = 0.0, sy = 0.0;
  for (int p = 0; p < n; ++p) {
    Sampler s;
    s.start(SamplerType::kSobol, 3, uint32_t(p), 0);
    Vec2f u = s.next_2d();
    sx += u.x;
    sy += u.y;
  }
  const double se = std::sqrt(1.0 / 12.0 / n);
  EXPECT_NEAR(sx / n, 0.5, 4.0 * se);  // 4 standard errors of the mean
  EXPECT_NEAR(sy / n, 0.5, 4.0 * se);  // 4 standard errors of the mean
}

TEST(Sobol, CoordinatesOfDifferentDimensionsAreUncorrelated) {
  // Across dimension pairs the points must pair up without a systematic link.
  // Per pixel, c = mean over its N samples of (x_a - 1/2)(x_b - 1/2). For
  // independent uniforms Var(c) = 1 / (144 N), so z = 144 N c^2 has mean 1. The
  // shuffle of Burley 2020 Sec. 4 (a nested scramble of the sample index per
  // dimension) pairs the two samples of each aligned index pair as a block:
  // both values of one dimension lie in opposite halves, and so do the other's,
  // so the block adds +-(|a1 b1| + |a2 b2|) with one random sign. With |a|
  // uniform on [0, 1/2], E[(|a1 b1| + |a2 b2|)^2] = 2/144 + 2/256, which makes
  // E[z] = 1 + 144/256 = 1.5625 (finer blocks add little: measured 1.42-1.75
  // over the pairs below). z is a scaled chi-square with one degree of
  // freedom, so its mean over P pixels has standard error sqrt(2) E[z] / sqrt(P).
  // Without a per-dimension shuffle (every dimension indexed alike) or with
  // shared seeds, z grows with N. Draws mix next_1d and next_2d as the
  // integrators do, at N = 64 (a full net) and 133 (a partial one).
  const int P = 2048, kDraws = 10;
  for (uint32_t N : {64u, 133u}) {
    // Per pixel and sample: the coordinates of draws 0..kDraws-1 (even draws 2D, odd 1D).
    std::vector<double> z;
    std::vector<int> owner;
    std::vector<double> x;
    int coords = 0;
    for (int d = 0; d < kDraws; ++d) {
      int c = d % 2 == 0 ? 2 : 1;
      for (int k = 0; k < c; ++k) owner.push_back(d);
      coords += c;
    }
    std::vector<double> zsum(size_t(coords) * coords, 0.0);
    std::vector<double> c(size_t(coords) * coords);
    x.resize(size_t(N) * coords);
    for (int p = 0; p < P; ++p) {
      for (uint32_t i = 0; i < N; ++i) {
        Sampler s;
        s.start(SamplerType::kSobol, 11, uint32_t(p), i);
        double* xi = &x[size_t(i) * coords];
        int j = 0;
        for (int d = 0; d < kDraws; ++d) {
          if (d % 2 == 0) {
            Vec2f u = s.next_2d();
            xi[j++] = u.x - 0.5;
            xi[j++] = u.y - 0.5;
          } else {
            xi[j++] = s.next_1d() - 0.5;
          }
        }
      }
      std::fill(c.begin(), c.end(), 0.0);
      for (uint32_t i = 0; i < N; ++i) {
        const double* xi = &x[size_t(i) * coords];
        for (int a = 0; a < coords; ++a)
          for (int b = a + 1; b < coords; ++b) c[size_t(a) * coords + b] += xi[a] * xi[b];
      }
      for (int a = 0; a < coords; ++a)
        for (int b = a + 1; b < coords; ++b) {
          double m = c[size_t(a) * coords + b] / N;
          zsum[size_t(a) * coords + b] += 144.0 * N * m * m;
        }
    }
    const double expected = 1.0 + 144.0 / 256.0, se = std::sqrt(2.0) * expected / std::sqrt(double(P));
    for (int a = 0; a < coords; ++a)
      for (int b = a + 1; b < coords; ++b) {
        if (owner[a] == owner[b]) continue;  // the two coordinates of one 2D point: a (0,2) net, not random
        double zm = zsum[size_t(a) * coords + b] / P;
        EXPECT_LT(zm, expected + 6.0 * se) << "N " << N << " coordinates " << a << ", " << b << " (draws " << owner[a]
                                      << ", " << owner[b] << ")";  // 6 standard errors
      }
  }
}

// ---------------------------------------------------------------------------
// PCG32 (the independent sampler).

namespace {
struct Moments {
  double n = 0, sum = 0, sum2 = 0, lag = 0, prev = 0.5;
  void add(double x) {
    if (n > 0) lag += (x - 0.5) * (prev - 0.5);
    prev = x;
    n += 1;
    sum += x;
    sum2 += x * x;
  }
  double mean() const { return sum / n; }
  double var() const { return sum2 / n - mean() * mean(); }
  double lag1() const { return lag / (n - 1); }
};
// Standard errors for N uniforms: mean sqrt(1/12/N); sample variance
// sqrt((mu4 - sigma^4)/N) with mu4 = 1/80, sigma^4 = 1/144, i.e. sqrt(1/180/N);
// lag-1 covariance of independent values sqrt(sigma^4/N) = 1/(12 sqrt(N)).
void expect_uniform(const Moments& m, const char* what) {
  const double n = m.n;
  EXPECT_NEAR(m.mean(), 0.5, 4.0 * std::sqrt(1.0 / 12.0 / n)) << what;        // 4 SE
  EXPECT_NEAR(m.var(), 1.0 / 12.0, 4.0 * std::sqrt(1.0 / 180.0 / n)) << what;  // 4 SE
  EXPECT_NEAR(m.lag1(), 0.0, 4.0 / (12.0 * std::sqrt(n))) << what;             // 4 SE
}
}  // namespace

TEST(Independent, OneStreamHasUniformMoments) {
  Sampler s;
  s.start(SamplerType::kIndependent, 17, 1234, 5);
  Moments m;
  for (int i = 0; i < 1000000; ++i) {
    float x = s.next_1d();
    ASSERT_TRUE(x >= 0.f && x < 1.f);
    m.add(x);
  }
  expect_uniform(m, "one stream");
}

TEST(Independent, FirstValuesAcrossStreamsHaveUniformMoments) {
  // The first value of 10^6 (pixel, sample index) streams: seeding must not
  // correlate neighbouring streams.
  Moments m;
  for (uint32_t i = 0; i < 1000000; ++i) {
    Sampler s;
    s.start(SamplerType::kIndependent, 17, i % 1000, i / 1000);
    float x = s.next_1d();
    ASSERT_TRUE(x >= 0.f && x < 1.f);
    m.add(x);
  }
  expect_uniform(m, "across streams");
}
