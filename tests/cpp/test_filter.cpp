// Pixel filters (film/filter.h): Mitsuba 3's filter values, the normalisations
// (h integrates to 1, as does the sampling density p), p > 0 wherever h != 0
// (so the weights h / p are unbiased), the samples follow p (chi-square,
// chi2.h), and the mean weight E[h / p] = 1.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>
#include <string>
#include <vector>

#include "caustica/base/rng.h"
#include "caustica/base/error.h"
#include "caustica/film/filter.h"
#include "chi2.h"

using namespace caustica;

namespace {

struct Named {
  std::string name;
  Filter f;
};

std::vector<Named> filters() {
  const float d = kFilterDefault;
  return {{"box", make_filter(FilterType::kBox)},
          {"box r=1.5", make_filter(FilterType::kBox, 1.5f)},
          {"tent", make_filter(FilterType::kTent)},
          {"tent r=2", make_filter(FilterType::kTent, 2.f)},
          {"gaussian", make_filter(FilterType::kGaussian)},
          {"gaussian s=0.3 r=1", make_filter(FilterType::kGaussian, 1.f, 0.3f)},
          {"mitchell", make_filter(FilterType::kMitchell)},
          {"catmullrom", filter_by_name("catmullrom")},
          {"mitchell B=0.2 C=0.4 r=3", make_filter(FilterType::kMitchell, 3.f, 0.2f, 0.4f)},
          {"lanczos", make_filter(FilterType::kLanczos)},
          {"lanczos lobes=2 r=4", make_filter(FilterType::kLanczos, 4.f, 2.f, d)}};
}

// Chi-square tests whose null hypothesis is true (one per filter), for the Sidak correction.
const int kNumChi2Tests = int(filters().size());

// The integral of g over [-r, r] by Simpson's rule on n intervals (n even).
template <typename G>
double simpson(G&& g, double r, int n) {
  const double h = 2.0 * r / n;
  double s = g(-r) + g(r);
  for (int i = 1; i < n; ++i) s += (i % 2 ? 4.0 : 2.0) * g(-r + i * h);
  return s * h / 3.0;
}

}  // namespace

// Mitsuba 3.9.1's rfilter eval() at the same offsets (scalar_rgb; `mi.load_dict({"type": ...}).eval(x)`),
// to the 5 digits printed. caustica's f1 is unnormalised as Mitsuba's is.
TEST(Filter, MatchesMitsubasFilterValues) {
  struct Case {
    Filter f;
    float x, mitsuba;
  };
  const Case cases[] = {
      {make_filter(FilterType::kTent, 2.f), 0.25f, 0.875f},   {make_filter(FilterType::kTent, 2.f), 1.5f, 0.25f},
      {make_filter(FilterType::kMitchell), 0.f, 0.88889f},
      {make_filter(FilterType::kMitchell), 0.25f, 0.78212f},  {make_filter(FilterType::kMitchell), 0.5f, 0.53472f},
      {make_filter(FilterType::kMitchell), 1.f, 0.05556f},    {make_filter(FilterType::kMitchell), 1.5f, -0.03472f},
      {make_filter(FilterType::kMitchell, kFilterDefault, 0.2f, 0.4f), 0.25f, 0.81615f},
      {make_filter(FilterType::kMitchell, kFilterDefault, 0.2f, 0.4f), 1.5f, -0.04583f},
      {filter_by_name("catmullrom"), 0.25f, 0.86719f},        {filter_by_name("catmullrom"), 1.5f, -0.0625f},
      {make_filter(FilterType::kLanczos), 0.25f, 0.89007f},   {make_filter(FilterType::kLanczos), 0.5f, 0.60793f},
      {make_filter(FilterType::kLanczos), 1.5f, -0.13509f},   {make_filter(FilterType::kLanczos), 2.5f, 0.02432f},
      {make_filter(FilterType::kLanczos, kFilterDefault, 2.f), 1.5f, -0.06368f},
  };
  for (const Case& c : cases) {
    // 5 printed digits: half a unit of the last one, plus float rounding.
    EXPECT_NEAR(filter_f1(c.f, c.x), c.mitsuba, 5e-6 + 1e-6) << filter_type_name(c.f.type) << " x=" << c.x;
    EXPECT_NEAR(filter_f1(c.f, -c.x), c.mitsuba, 5e-6 + 1e-6) << filter_type_name(c.f.type) << " x=" << -c.x;
  }
  // Mitsuba's gaussian evaluates its exponential approximately (0.99925 at 0, where 1 - e^-8 = 0.99966;
  // 0.13496 at 1 against e^-2 - e^-8 = 0.13500): compared to 5e-4, that approximation's size here.
  const Filter g = make_filter(FilterType::kGaussian);
  for (auto [x, v] : {std::pair{0.f, 0.99925f}, {0.25f, 0.88217f}, {1.f, 0.13496f}, {1.5f, 0.01076f}})
    EXPECT_NEAR(filter_f1(g, x), v, 5e-4) << "gaussian x=" << x;
  // Zero from the radius on (and Mitsuba's gaussian radius is 4 stddev).
  EXPECT_EQ(filter_f1(make_filter(FilterType::kMitchell), 2.f), 0.f);
  EXPECT_EQ(make_filter(FilterType::kGaussian, kFilterDefault, 0.3f).radius, 1.2f);
  EXPECT_EQ(make_filter(FilterType::kLanczos, kFilterDefault, 2.f).radius, 2.f);
}

TEST(Filter, NormalisedAndSampledWhereverNonZero) {
  for (const Named& n : filters()) {
    const Filter& f = n.f;
    const double r = f.radius;
    // Simpson on 2^16 intervals: the box and the table's steps (at most 64 + 2 kinks) leave errors of order
    // (step height) x (interval) ~ 1e-4 / 16 per step; 5e-4 in all.
    const double H = simpson([&](double x) { return double(filter_h1(f, float(x))); }, r, 1 << 16);
    const double P = simpson([&](double x) { return double(filter_p1(f, float(x))); }, r, 1 << 16);
    EXPECT_NEAR(H, 1.0, 5e-4) << n.name;
    EXPECT_NEAR(P, 1.0, 5e-4) << n.name;
    for (int i = 0; i <= 4000; ++i) {
      const float x = float(-r + 2.0 * r * i / 4000.0);
      if (filter_h1(f, x) != 0.f) EXPECT_GT(filter_p1(f, x), 0.f) << n.name << " x=" << x;
    }
  }
}

TEST(Filter, SamplesFollowTheDensity) {
  for (const Named& n : filters()) {
    const Filter& f = n.f;
    const double r = f.radius;
    PCG32 rng(7, 0x5eed);
    chi2::Options o;
    o.samples = 400000;
    o.alpha = 0.01;
    o.n_tests = kNumChi2Tests;
    // 32 x 32 bins: their edges are every other table bin's, so the tabulated density is smooth inside each.
    const chi2::Grid g{-r, r, -r, r, 32, 32};
    auto sample = [&]() {
      const float a = rng.next_float(), b = rng.next_float();
      const FilterSample s = filter_sample(f, Vec2f(a, b));
      return chi2::Sample2{s.pdf > 0.f, s.offset.x, s.offset.y, false};
    };
    auto density = [&](double x, double y) {
      return double(filter_p1(f, float(x))) * double(filter_p1(f, float(y)));
    };
    const chi2::Result res = chi2::test_2d(g, sample, density, o);
    EXPECT_TRUE(res.passed) << n.name << ": " << res.report;
    EXPECT_EQ(res.bad_samples, 0) << n.name;
  }
}

TEST(Filter, MeanWeightIsOne) {
  // E[h / p] = the integral of h = 1; the weights' sample mean within 4 standard errors (their own sample
  // standard deviation / sqrt(N)) plus 1e-4 for the normalisations' quadrature.
  for (const Named& n : filters()) {
    PCG32 rng(11, 0xf11);
    const int N = 200000;
    double s = 0.0, s2 = 0.0;
    for (int i = 0; i < N; ++i) {
      const float a = rng.next_float(), b = rng.next_float();
      const double w = filter_sample(n.f, Vec2f(a, b)).weight;
      s += w;
      s2 += w * w;
    }
    const double mean = s / N, var = s2 / N - mean * mean;
    EXPECT_NEAR(mean, 1.0, 4.0 * std::sqrt(var / N) + 1e-4) << n.name;
  }
  // The negative lobes give negative weights (the sign of h is kept).
  const Filter m = make_filter(FilterType::kMitchell);
  // u = 0.005: inside the first 1.3% of |k|'s mass, the lobe on [-2, -1] where k < 0.
  EXPECT_LT(filter_sample(m, Vec2f(0.005f, 0.5f)).weight, 0.f);
}

TEST(Filter, InvalidParametersAreErrors) {
  EXPECT_THROW(make_filter(FilterType::kGaussian, kFilterDefault, 0.f), InputError);
  EXPECT_THROW(make_filter(FilterType::kTent, 0.f), InputError);
  EXPECT_THROW(make_filter(FilterType::kGaussian, kFilterDefault, 1e-5f), InputError);  // radius 4e-5 < 0.001
  EXPECT_THROW(make_filter(FilterType::kBox, 17.f), InputError);
  EXPECT_THROW(make_filter(FilterType::kLanczos, kFilterDefault, 0.5f), InputError);
  EXPECT_THROW(make_filter(FilterType::kMitchell, kFilterDefault, 11.f), InputError);
  EXPECT_THROW(filter_by_name("bicubic"), InputError);
  EXPECT_TRUE(filter_by_name("catmullrom") == make_filter(FilterType::kMitchell, 2.f, 0.f, 0.5f));
}
