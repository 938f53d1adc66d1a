// SmallVCM's glossy material: Lambert Kd plus the modified Phong lobe of
// Lafortune & Willems 1994 ("Using the modified Phong reflectance model for
// physically based rendering"), f = Kd/pi + Ks (n+2)/(2 pi) max(0, r.wi)^n,
// r = wo mirrored about the normal. Sampling picks the lobe in proportion to
// the luminance of Kd and Ks; the Phong lobe draws cos(alpha) = u^(1/(n+1))
// around r, density (n+1)/(2 pi) cos^n(alpha).
#pragma once
#include "../base/sampling.h"
#include "material.h"

namespace caustica {

CHD float phong_diffuse_prob(const Material& m) {
  float d = luminance(m.diffuse), s = luminance(m.specular);
  return d + s > 0.f ? d / (d + s) : 1.f;
}
CHD RGB phong_eval(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return RGB(0.f);
  Vec3f r(-wo.x, -wo.y, wo.z);
  float c = dot(r, wi);
  float lobe = c > 0.f ? (m.exponent + 2.f) * kInv2Pi * std::pow(c, m.exponent) : 0.f;
  return m.diffuse * kInvPi + m.specular * lobe;
}
CHD float phong_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return 0.f;
  float pd = phong_diffuse_prob(m);
  Vec3f r(-wo.x, -wo.y, wo.z);
  float c = dot(r, wi);
  float lobe = c > 0.f ? (m.exponent + 1.f) * kInv2Pi * std::pow(c, m.exponent) : 0.f;
  return pd * wi.z * kInvPi + (1.f - pd) * lobe;
}
CHD bool phong_sample(const Material& m, Vec3f wo, float uc, Vec2f u, BSDFSample& s) {
  if (wo.z <= 0.f) return false;
  float pd = phong_diffuse_prob(m);
  if (uc < pd) {
    s.wi = square_to_cosine_hemisphere(u);
  } else {
    float cos_a = std::pow(u.x, 1.f / (m.exponent + 1.f));
    float sin_a = safe_sqrt(1.f - cos_a * cos_a);
    float phi = 2.f * kPi * u.y;
    Frame f(Vec3f(-wo.x, -wo.y, wo.z));
    s.wi = f.to_world(Vec3f(sin_a * std::cos(phi), sin_a * std::sin(phi), cos_a));
  }
  if (s.wi.z <= 0.f) return false;
  s.pdf = phong_pdf(m, wo, s.wi);
  if (!(s.pdf > 0.f)) return false;
  s.weight = phong_eval(m, wo, s.wi) * (s.wi.z / s.pdf);
  s.delta = false;
  s.eta = 1.f;
  return true;
}

}  // namespace caustica
