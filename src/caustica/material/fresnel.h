// Fresnel equations and Snell refraction.
// Dielectric: the unpolarised average of the s and p reflectances (Born & Wolf;
// pbrt-v4 Eq. 9.6); conductor: the same with a complex index eta + i k
// (pbrt-v4 Eq. 9.7 / the "FrComplex" form), evaluated per RGB channel.
#pragma once
#include "../base/math.h"

namespace caustica {

// Schlick's weight (1 - c)^5 (Schlick 1994, Eq. 24), c clamped to [0, 1].
CHD float schlick_weight(float c) {
  const float m = clampf(1.f - c, 0.f, 1.f);
  return (m * m) * (m * m) * m;
}

// cos_i: cosine on the incident side (negative: from inside); eta = eta_t / eta_i
// for a ray arriving from outside.
CHD float fresnel_dielectric(float cos_i, float eta) {
  cos_i = clampf(cos_i, -1.f, 1.f);
  if (cos_i < 0.f) { eta = 1.f / eta; cos_i = -cos_i; }
  float sin2_i = 1.f - cos_i * cos_i;
  float sin2_t = sin2_i / (eta * eta);
  if (sin2_t >= 1.f) return 1.f;  // total internal reflection
  float cos_t = safe_sqrt(1.f - sin2_t);
  float r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5f * (r_par * r_par + r_perp * r_perp);
}

struct Complexf {
  float re, im;
};
CHD Complexf cadd(Complexf a, Complexf b) { return {a.re + b.re, a.im + b.im}; }
CHD Complexf csub(Complexf a, Complexf b) { return {a.re - b.re, a.im - b.im}; }
CHD Complexf cmul(Complexf a, Complexf b) { return {a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re}; }
CHD Complexf cdiv(Complexf a, Complexf b) {
  float s = 1.f / (b.re * b.re + b.im * b.im);
  return {(a.re * b.re + a.im * b.im) * s, (a.im * b.re - a.re * b.im) * s};
}
CHD float cnorm(Complexf a) { return a.re * a.re + a.im * a.im; }
CHD Complexf csqrt(Complexf z) {
  float n = std::sqrt(std::sqrt(cnorm(z)));
  if (n == 0.f) return {0.f, 0.f};
  float t1 = std::sqrt(0.5f * (n * n + std::fabs(z.re)));  // |sqrt| real part for z.re >= 0
  float t2 = 0.5f * z.im / t1;
  if (z.re >= 0.f) return {t1, t2};
  return {std::fabs(t2), std::copysign(t1, z.im)};
}

CHD float fresnel_complex(float cos_i, float eta, float k) {
  cos_i = clampf(cos_i, 0.f, 1.f);
  Complexf e{eta, k};
  float sin2_i = 1.f - cos_i * cos_i;
  Complexf sin2_t = cdiv({sin2_i, 0.f}, cmul(e, e));
  Complexf cos_t = csqrt(csub({1.f, 0.f}, sin2_t));
  Complexf ci{cos_i, 0.f};
  Complexf r_par = cdiv(csub(cmul(e, ci), cos_t), cadd(cmul(e, ci), cos_t));
  Complexf r_perp = cdiv(csub(ci, cmul(e, cos_t)), cadd(ci, cmul(e, cos_t)));
  return 0.5f * (cnorm(r_par) + cnorm(r_perp));
}

CHD RGB fresnel_conductor(float cos_i, RGB eta, RGB k) {
  return {fresnel_complex(cos_i, eta.x, k.x), fresnel_complex(cos_i, eta.y, k.y),
          fresnel_complex(cos_i, eta.z, k.z)};
}

// Refracts wi (pointing away from the surface) about n (same side as wi).
// eta = eta_t / eta_i. Returns false on total internal reflection.
CHD bool refract(Vec3f wi, Vec3f n, float eta, Vec3f& wt) {
  float cos_i = dot(n, wi);
  float sin2_i = maxf(0.f, 1.f - cos_i * cos_i);
  float sin2_t = sin2_i / (eta * eta);
  if (sin2_t >= 1.f) return false;
  float cos_t = safe_sqrt(1.f - sin2_t);
  wt = -wi / eta + (cos_i / eta - cos_t) * n;
  return true;
}

}  // namespace caustica
