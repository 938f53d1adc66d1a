// Pixel reconstruction filters, applied by filter importance sampling (Ernst
// et al. 2006, "Filter Importance Sampling"; pbrt-v4 Sec. 8.8): each camera
// sample's offset d from the pixel centre is drawn with a density p(d), and
// the sample measures the normalised filter h(d) = f(d) / ∫f, so its weight is
// h(d) / p(d) (mean 1). A sample only touches its own pixel (no splatting
// across pixels: threads never share a pixel and the image is independent of
// the schedule); the path tracer's film divides by the sum of weights, the
// photon mappers and vcm by the number of passes.
//
// Every filter is separable, f(x, y) = f1(x) f1(y), and zero outside
// [-radius, radius] per axis (radii in pixels; defaults are Mitsuba 3's):
//   box:      f1 = 1 on [-r, r) (half-open, so that radius 1/2 gives each point
//             exactly one pixel); p = h. Default r = 1/2.
//   tent:     f1 = 1 - |x| / r, sampled by the inverse CDF; p = h. Default r = 1.
//   gaussian: f1 = max(0, g(x) - g(r)), g(x) = exp(-x^2 / (2 s^2)); default
//             s = 1/2 and r = 4 s (Mitsuba's). The untruncated g is sampled
//             exactly through erf^-1 (p = g / G, G its integral over [-r, r]).
//   mitchell: f1 = k(2 x / r) (default r = 2, so k(x) itself), k the cubic of
//             Mitchell & Netravali 1988 ("Reconstruction Filters in Computer
//             Graphics") with parameters B and C (1/3, 1/3; catmullrom is B = 0,
//             C = 1/2); it has negative lobes.
//   lanczos:  f1 = sinc(x) sinc(x / tau) (sinc(x) = sin(pi x) / (pi x); pbrt-v4's
//             windowed sinc, Mitsuba's lanczos), tau = lobes (3), r = tau by default.
// Mitchell and Lanczos are sampled from |f1| tabulated over kFilterBins equal
// bins (piecewise-constant density, as pbrt-v4's FilterSampler tabulates
// |f|): where f1 < 0 the weight h / p is negative, so the estimate stays the
// signed filter's, ringing included.
#pragma once
#include <cstdint>
#include <limits>
#include <string>

#include "../base/math.h"
#include "../base/sampling.h"

namespace caustica {

enum class FilterType : uint32_t { kBox = 0, kTent, kGaussian, kMitchell, kLanczos };

constexpr int kFilterBins = 64;

struct Filter {
  FilterType type = FilterType::kBox;
  float radius = 0.5f;     // pixels: f1 = 0 for |x| >= radius
  float a = 0.f, b = 0.f;  // gaussian: stddev; mitchell: B, C; lanczos: tau (lobes)
  float norm = 1.f;        // 1 / the integral of f1 over [-radius, radius]: h1 = f1 norm
  float gauss_g = 1.f;     // gaussian: the integral G of the untruncated g over [-radius, radius]
  // mitchell, lanczos: the CDF of |f1| over kFilterBins equal bins of [-radius, radius] (cdf[0] = 0,
  // cdf[kFilterBins] = 1).
  float cdf[kFilterBins + 1] = {};
};

// The same filter: the same type and parameters (the rest is derived from them).
CHD bool operator==(const Filter& x, const Filter& y) {
  return x.type == y.type && x.radius == y.radius && x.a == y.a && x.b == y.b;
}

struct FilterSample {
  Vec2f offset;
  float weight;  // h / p: h the normalised filter at the offset, p its sampling density
  float pdf;     // p per unit raster area
};

CHD float tent_sample(float u) {
  return u < 0.5f ? -1.f + std::sqrt(2.f * u) : 1.f - std::sqrt(2.f - 2.f * u);
}

CHD float sinc_pi(float x) {  // sin(pi x) / (pi x)
  const float px = 3.14159265358979f * x;
  return std::fabs(px) < 1e-4f ? 1.f - px * px / 6.f : std::sin(px) / px;
}

// The Mitchell-Netravali cubic k(x) on [-2, 2] (zero beyond).
CHD float mitchell_k(float x, float B, float C) {
  x = std::fabs(x);
  if (x >= 2.f) return 0.f;
  if (x >= 1.f)
    return ((-B - 6.f * C) * x * x * x + (6.f * B + 30.f * C) * x * x + (-12.f * B - 48.f * C) * x +
            (8.f * B + 24.f * C)) * (1.f / 6.f);
  return ((12.f - 9.f * B - 6.f * C) * x * x * x + (-18.f + 12.f * B + 6.f * C) * x * x + (6.f - 2.f * B)) *
         (1.f / 6.f);
}

// The filter f1 along one axis, unnormalised.
CHD float filter_f1(const Filter& f, float x) {
  const float r = f.radius;
  if (!(x >= -r && x < r)) return 0.f;  // half-open (for the box; the others are 0 at +-r anyway)
  switch (f.type) {
    case FilterType::kTent: return 1.f - std::fabs(x) / r;
    case FilterType::kGaussian: {
      const float s2 = 2.f * f.a * f.a;
      return maxf(0.f, std::exp(-x * x / s2) - std::exp(-r * r / s2));
    }
    case FilterType::kMitchell: return mitchell_k(2.f * x / r, f.a, f.b);
    case FilterType::kLanczos: return sinc_pi(x) * sinc_pi(x / f.a);
    default: return 1.f;
  }
}

// The normalised filter h1 along one axis (its integral is 1).
CHD float filter_h1(const Filter& f, float x) { return filter_f1(f, x) * f.norm; }

// The sampling density along one axis at offset x.
CHD float filter_p1(const Filter& f, float x) {
  const float r = f.radius;
  if (!(x >= -r && x < r)) return 0.f;
  switch (f.type) {
    case FilterType::kBox:
    case FilterType::kTent: return filter_h1(f, x);
    case FilterType::kGaussian: return std::exp(-x * x / (2.f * f.a * f.a)) / f.gauss_g;
    default: {
      const float w = 2.f * r / float(kFilterBins);
      int i = int((x + r) / w);
      i = i < 0 ? 0 : i >= kFilterBins ? kFilterBins - 1 : i;
      return (f.cdf[i + 1] - f.cdf[i]) / w;
    }
  }
}

// An offset along one axis with density filter_p1 (u in [0, 1)).
CHD float filter_sample1(const Filter& f, float u) {
  const float r = f.radius;
  switch (f.type) {
    case FilterType::kBox: return (2.f * u - 1.f) * r;
    case FilterType::kTent: return r * tent_sample(u);
    case FilterType::kGaussian: {
      const float k = 1.41421356f * f.a;
      const float e = std::erf(r / k);
      return clampf(k * erf_inv(clampf((2.f * u - 1.f) * e, -0.99999994f, 0.99999994f)), -r, r);
    }
    default: {
      int lo = 0, hi = kFilterBins;  // the bin i with cdf[i] <= u < cdf[i + 1]
      while (hi - lo > 1) {
        const int mid = (lo + hi) / 2;
        if (f.cdf[mid] <= u) lo = mid;
        else hi = mid;
      }
      const float c0 = f.cdf[lo], c1 = f.cdf[lo + 1];
      const float t = c1 > c0 ? minf((u - c0) / (c1 - c0), 0.99999994f) : 0.5f;
      const float w = 2.f * r / float(kFilterBins);
      return -r + (float(lo) + t) * w;
    }
  }
}

CHD FilterSample filter_sample(const Filter& f, Vec2f u) {
  const Vec2f d(filter_sample1(f, u.x), filter_sample1(f, u.y));
  const float p = filter_p1(f, d.x) * filter_p1(f, d.y);
  const float h = filter_h1(f, d.x) * filter_h1(f, d.y);
  return {d, p > 0.f ? h / p : 0.f, p};
}

// Host-side set-up (film/filter.cpp). make_filter: the filter of a type with the given parameters (NaN: the
// type's default; a and b as Filter's), its normalisation and table computed; invalid parameters throw
// InputError naming them. filter_by_name: box, tent, gaussian, mitchell, catmullrom (mitchell with B = 0,
// C = 1/2) or lanczos with their defaults; another name throws InputError listing these.
constexpr float kFilterDefault = std::numeric_limits<float>::quiet_NaN();
Filter make_filter(FilterType type, float radius = kFilterDefault, float a = kFilterDefault,
                   float b = kFilterDefault);
Filter filter_by_name(const std::string& name);
const char* filter_type_name(FilterType t);
constexpr const char* kFilterNames = "box, tent, gaussian, mitchell, catmullrom, lanczos";

}  // namespace caustica
