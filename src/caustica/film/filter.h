// Pixel reconstruction filters, applied by filter importance sampling (Ernst
// et al. 2006, "Filter Importance Sampling"; pbrt-v4 Sec. 8.8): each camera
// sample's offset from the pixel centre is drawn from the filter itself, so a
// sample only touches its own pixel (no splatting across pixels: threads never
// share a pixel and the image is independent of the schedule). The returned
// weight is f(x)/p(x); the film divides by the sum of weights.
//   box:      radius 1/2, constant.
//   tent:     radius 1, f = (1 - |x|)(1 - |y|), sampled by the inverse CDF.
//   gaussian: stddev 1/2, radius 2 (Mitsuba's default), f = max(0, g(x) - g(2))
//             per axis; the untruncated part exp(-x^2/(2 s^2)) is sampled
//             exactly through erf^-1 and the weight is 1 - g(2)/g(x).
#pragma once
#include "../base/math.h"
#include "../base/sampling.h"

namespace caustica {

enum class FilterType : uint32_t { kBox = 0, kTent, kGaussian };

struct FilterSample {
  Vec2f offset;
  float weight;
};

CHD float tent_sample(float u) {
  return u < 0.5f ? -1.f + std::sqrt(2.f * u) : 1.f - std::sqrt(2.f - 2.f * u);
}

CHD FilterSample filter_sample(FilterType type, Vec2f u) {
  switch (type) {
    case FilterType::kTent: return {{tent_sample(u.x), tent_sample(u.y)}, 1.f};
    case FilterType::kGaussian: {
      const float sigma = 0.5f, radius = 2.f;
      const float k = 1.41421356f * sigma;
      const float erf_r = std::erf(radius / k);
      float x = k * erf_inv(clampf((2.f * u.x - 1.f) * erf_r, -0.99999994f, 0.99999994f));
      float y = k * erf_inv(clampf((2.f * u.y - 1.f) * erf_r, -0.99999994f, 0.99999994f));
      const float g_r = std::exp(-radius * radius / (2.f * sigma * sigma));
      float wx = 1.f - g_r / std::exp(-x * x / (2.f * sigma * sigma));
      float wy = 1.f - g_r / std::exp(-y * y / (2.f * sigma * sigma));
      return {{x, y}, maxf(0.f, wx) * maxf(0.f, wy)};
    }
    default: return {{u.x - 0.5f, u.y - 0.5f}, 1.f};
  }
}

}  // namespace caustica
