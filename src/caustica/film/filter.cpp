// Pixel filters' host-side set-up: defaults, checks, normalisation and the
// sampling tables of the filters with negative lobes (film/filter.h).
#include "filter.h"

#include <cmath>
#include <algorithm>
#include <string>

#include "../base/error.h"

namespace caustica {

namespace {

// The integral of f(x) over [lo, hi] by the composite Simpson rule on n (even) intervals.
template <typename F>
double simpson(F&& f, double lo, double hi, int n) {
  const double h = (hi - lo) / n;
  double s = f(lo) + f(hi);
  for (int i = 1; i < n; ++i) s += (i % 2 ? 4.0 : 2.0) * f(lo + i * h);
  return s * h / 3.0;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw InputError(what);
}

}  // namespace

Filter make_filter(FilterType type, float radius, float a, float b) {
  Filter f;
  f.type = type;
  const double kPi = 3.14159265358979323846;
  auto given = [](float v, float fallback) { return std::isnan(v) ? fallback : v; };
  switch (type) {
    case FilterType::kBox: f.radius = given(radius, 0.5f); break;
    case FilterType::kTent: f.radius = given(radius, 1.f); break;
    case FilterType::kGaussian:
      f.a = given(a, 0.5f);
      require(std::isfinite(f.a) && f.a > 0.f, "the gaussian filter's stddev must be positive");
      f.radius = given(radius, 4.f * f.a);
      break;
    case FilterType::kMitchell:
      f.radius = given(radius, 2.f);
      f.a = given(a, 1.f / 3.f);
      f.b = given(b, 1.f / 3.f);
      require(std::fabs(f.a) <= 10.f && std::fabs(f.b) <= 10.f, "the mitchell filter's B and C must be in [-10, 10]");
      break;
    case FilterType::kLanczos:
      f.a = given(a, 3.f);
      require(f.a >= 1.f && f.a <= 16.f, "the lanczos filter's lobes must be in [1, 16]");
      f.radius = given(radius, f.a);
      break;
  }
  require(f.radius >= 1e-3f && f.radius <= 16.f, "a pixel filter's radius must be in [0.001, 16] pixels");
  const double r = f.radius;
  switch (type) {
    case FilterType::kBox: f.norm = float(1.0 / (2.0 * r)); break;
    case FilterType::kTent: f.norm = float(1.0 / r); break;
    case FilterType::kGaussian: {
      // G = s sqrt(2 pi) erf(r / (s sqrt 2)); F = G - 2 r g(r).
      const double s = f.a;
      const double G = s * std::sqrt(2.0 * kPi) * std::erf(r / (s * std::sqrt(2.0)));
      f.gauss_g = float(G);
      f.norm = float(1.0 / (G - 2.0 * r * std::exp(-r * r / (2.0 * s * s))));
      break;
    }
    case FilterType::kMitchell: f.norm = float(2.0 / r); break;  // k integrates to 1 over [-2, 2] for all B, C
    case FilterType::kLanczos: {
      const double tau = f.a;
      auto sinc = [&](double x) { return std::fabs(x) < 1e-12 ? 1.0 : std::sin(kPi * x) / (kPi * x); };
      const double F = simpson([&](double x) { return sinc(x) * sinc(x / tau); }, -r, r, 1 << 14);
      require(F > 1e-3, "the lanczos filter's radius and lobes give a filter of integral 0");
      f.norm = float(1.0 / F);
      break;
    }
  }
  if (type == FilterType::kMitchell || type == FilterType::kLanczos) {
    // |f1| averaged over each bin (Simpson on 32 intervals per bin), accumulated and normalised.
    const double w = 2.0 * r / kFilterBins;
    double acc[kFilterBins + 1] = {0.0};
    for (int i = 0; i < kFilterBins; ++i) {
      const double lo = -r + i * w;
      const double m = simpson([&](double x) { return std::fabs(double(filter_f1(f, float(x)))); }, lo,
                               i + 1 == kFilterBins ? r * (1.0 - 1e-9) : lo + w, 32);
      acc[i + 1] = acc[i] + std::max(m, 1e-6 * w);  // no empty bin: every offset keeps a density
    }
    for (int i = 0; i <= kFilterBins; ++i) f.cdf[i] = float(acc[i] / acc[kFilterBins]);
    f.cdf[kFilterBins] = 1.f;
  }
  return f;
}

Filter filter_by_name(const std::string& name) {
  if (name == "box") return make_filter(FilterType::kBox);
  if (name == "tent") return make_filter(FilterType::kTent);
  if (name == "gaussian") return make_filter(FilterType::kGaussian);
  if (name == "mitchell") return make_filter(FilterType::kMitchell);
  if (name == "catmullrom") return make_filter(FilterType::kMitchell, kFilterDefault, 0.f, 0.5f);
  if (name == "lanczos") return make_filter(FilterType::kLanczos);
  throw InputError("unknown filter '" + name + "' (allowed: " + kFilterNames + ")");
}

const char* filter_type_name(FilterType t) {
  switch (t) {
    case FilterType::kTent: return "tent";
    case FilterType::kGaussian: return "gaussian";
    case FilterType::kMitchell: return "mitchell";
    case FilterType::kLanczos: return "lanczos";
    default: return "box";
  }
}

}  // namespace caustica
