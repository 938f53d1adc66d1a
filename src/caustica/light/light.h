// Lights as a tagged struct: diffuse area lights on triangles and spheres (one-
// or two-sided), point, spot, directional and constant environment lights.
// sample_li() returns radiance arriving at a reference point with the solid-
// angle density of the direction (pbrt-v4 Sec. 12.2-12.5; sphere cone
// sampling: pbrt-v4 Sec. 6.2.4 / Shirley & Wang 1996).
#pragma once
#include <cstdint>
#include "../base/math.h"
#include "../base/sampling.h"
#include "../geometry/shapes.h"

namespace caustica {

enum class LightType : uint32_t { kTriangle = 0, kSphere, kPoint, kSpot, kDirectional, kEnvironment };

struct Light {
  LightType type = LightType::kPoint;
  uint32_t two_sided = 0;
  RGB L{0.f};      // area/environment: radiance; point/spot: intensity; directional: irradiance
  uint32_t prim = 0;  // area lights: the primitive (triangle index, or num_triangles + sphere index)
  Vec3f p;         // point, spot: position
  Vec3f dir{0, 0, -1};  // spot: axis; directional: the direction light travels
  float cos_total = 0.f, cos_falloff_start = 1.f;  // spot cone
  int32_t texture = -1;  // area: emission texture (multiplies L); environment: equirectangular map
  // Spot: the falloff between the cone angles is linear in the angle (Mitsuba 3's spot) rather than pbrt-v4's
  // smoothstep in cos(angle).
  uint32_t spot_linear_angle = 0;
};

CHD bool light_is_delta(const Light& l) {
  return l.type == LightType::kPoint || l.type == LightType::kSpot || l.type == LightType::kDirectional;
}
CHD bool light_is_infinite(const Light& l) {
  return l.type == LightType::kDirectional || l.type == LightType::kEnvironment;
}

// Radiance leaving an area light at a point with geometric normal n towards w
// (before its emission texture, see area_radiance in light_sample.h).
CHD RGB area_le(const Light& l, Vec3f n, Vec3f w) {
  float c = dot(n, w);
  if (c > 0.f || (l.two_sided && c < 0.f)) return l.L;
  return RGB(0.f);
}

// The spot's falloff between its two cone angles: pbrt-v4's SpotLight::I, a smoothstep in cos(angle), or with
// spot_linear_angle Mitsuba 3's, (cutoff - angle) / (cutoff - beam width). 1 inside the inner cone, 0 outside
// the outer one in both.
CHD float spot_falloff(const Light& l, float cos_theta) {
  if (cos_theta >= l.cos_falloff_start) return 1.f;
  if (cos_theta <= l.cos_total) return 0.f;
  if (l.spot_linear_angle) {
    const float total = std::acos(l.cos_total), start = std::acos(l.cos_falloff_start);
    return clampf((total - std::acos(cos_theta)) / (total - start), 0.f, 1.f);
  }
  float t = (cos_theta - l.cos_total) / (l.cos_falloff_start - l.cos_total);
  return t * t * (3.f - 2.f * t);
}

}  // namespace caustica
