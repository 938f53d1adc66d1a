// Sampling warps from [0,1)^2 to common domains, each with its density.
// Cosine hemisphere via Malley's method on Shirley & Chiu's concentric disk
// (Shirley & Chiu 1997, "A Low Distortion Map Between Disk and Square");
// uniform sphere and cone (pbrt-v4 sections A.5.2, A.5.4); uniform triangle by
// the square-root parameterisation (Turk 1990, Osada et al. 2002 Eq. 1).
#pragma once
#include "host_device.h"
#include "math.h"

namespace caustica {

CHD Vec2f square_to_concentric_disk(Vec2f u) {
  float ox = 2.f * u.x - 1.f, oy = 2.f * u.y - 1.f;
  if (ox == 0.f && oy == 0.f) return {0.f, 0.f};
  // Angle theta = pi/4 * oy/ox, or pi/2 - pi/4 * ox/oy (Shirley & Chiu 1997);
  // with a = the pi/4 part, |a| <= pi/4 and cos/sin(pi/2 - a) = sin/cos a.
  float s, c;
  if (std::fabs(ox) > std::fabs(oy)) {
    sincos_quarter_pi((kPi / 4.f) * (oy / ox), s, c);
    return {ox * c, ox * s};
  }
  sincos_quarter_pi((kPi / 4.f) * (ox / oy), s, c);
  return {oy * s, oy * c};
}
CHD float concentric_disk_pdf() { return kInvPi; }

CHD Vec3f square_to_cosine_hemisphere(Vec2f u) {
  Vec2f d = square_to_concentric_disk(u);
  float z = safe_sqrt(1.f - d.x * d.x - d.y * d.y);
  return {d.x, d.y, z};
}
CHD float cosine_hemisphere_pdf(Vec3f w) { return w.z > 0.f ? w.z * kInvPi : 0.f; }

CHD Vec3f square_to_uniform_sphere(Vec2f u) {
  float z = 1.f - 2.f * u.x;
  float r = safe_sqrt(1.f - z * z);
  float phi = 2.f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
CHD float uniform_sphere_pdf() { return kInv4Pi; }

CHD Vec3f square_to_uniform_hemisphere(Vec2f u) {
  float z = u.x;
  float r = safe_sqrt(1.f - z * z);
  float phi = 2.f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
CHD float uniform_hemisphere_pdf() { return kInv2Pi; }

// Uniform over the cone of directions within angle theta_max of +z.
CHD Vec3f square_to_uniform_cone(Vec2f u, float cos_theta_max) {
  float cos_t = (1.f - u.x) + u.x * cos_theta_max;
  float sin_t = safe_sqrt(1.f - cos_t * cos_t);
  float phi = 2.f * kPi * u.y;
  return {sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
}
CHD float uniform_cone_pdf(float cos_theta_max) {
  return 1.f / (2.f * kPi * (1.f - cos_theta_max));
}

// Barycentrics (b1, b2) uniform over a triangle; b0 = 1 - b1 - b2.
CHD Vec2f square_to_uniform_triangle(Vec2f u) {
  float su = std::sqrt(u.x);
  return {1.f - su, u.y * su};
}

// Power heuristic with beta = 2 (Veach 1997, Eq. 9.13), one sample per strategy.
CHD float power_heuristic(float pdf_a, float pdf_b) {
  float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
  if (a == kInf) return 1.f;
  return a > 0.f ? a / (a + b) : 0.f;
}

// Inverse error function: the single-precision approximation of Giles 2010
// ("Approximating the erfinv function", GPU Computing Gems), used by the
// Gaussian pixel filter's exact importance sampling.
CHD float erf_inv(float x) {
  float w = -std::log(maxf((1.f - x) * (1.f + x), 1e-30f));
  float p;
  if (w < 5.f) {
    w = w - 2.5f;
    p = 2.81022636e-08f;
    p = 3.43273939e-07f + p * w;
    p = -3.5233877e-06f + p * w;
    p = -4.39150654e-06f + p * w;
    p = 0.00021858087f + p * w;
    p = -0.00125372503f + p * w;
    p = -0.00417768164f + p * w;
    p = 0.246640727f + p * w;
    p = 1.50140941f + p * w;
  } else {
    w = std::sqrt(w) - 3.f;
    p = -0.000200214257f;
    p = 0.000100950558f + p * w;
    p = 0.00134934322f + p * w;
    p = -0.00367342844f + p * w;
    p = 0.00573950773f + p * w;
    p = -0.0076224613f + p * w;
    p = 0.00943887047f + p * w;
    p = 1.00167406f + p * w;
    p = 2.83297682f + p * w;
  }
  return p * x;
}

}  // namespace caustica
