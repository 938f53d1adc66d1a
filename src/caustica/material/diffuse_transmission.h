// Diffuse transmission (pbrt-v4's DiffuseTransmissionBxDF, Mitsuba's
// difftrans): Lambertian reflection R/pi on the side of wo and Lambertian
// transmission T/pi on the other; the lobe is chosen in proportion to luminance.
#pragma once
#include "../base/sampling.h"
#include "material.h"

namespace caustica {

CHD float difftrans_reflect_prob(const Material& m) {
  float r = luminance(m.diffuse), t = luminance(m.transmission);
  return r + t > 0.f ? r / (r + t) : 0.5f;
}
CHD RGB difftrans_eval(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z == 0.f || wi.z == 0.f) return RGB(0.f);
  return (same_hemisphere(wo, wi) ? m.diffuse : m.transmission) * kInvPi;
}
CHD float difftrans_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z == 0.f || wi.z == 0.f) return 0.f;
  float pr = difftrans_reflect_prob(m);
  return (same_hemisphere(wo, wi) ? pr : 1.f - pr) * std::fabs(wi.z) * kInvPi;
}
CHD bool difftrans_sample(const Material& m, Vec3f wo, float uc, Vec2f u, BSDFSample& s) {
  if (wo.z == 0.f) return false;
  float pr = difftrans_reflect_prob(m);
  Vec3f w = square_to_cosine_hemisphere(u);
  bool refl = uc < pr;
  float side = (wo.z > 0.f) == refl ? 1.f : -1.f;
  s.wi = Vec3f(w.x, w.y, w.z * side);
  s.pdf = (refl ? pr : 1.f - pr) * w.z * kInvPi;
  if (!(s.pdf > 0.f)) return false;
  s.weight = (refl ? m.diffuse : m.transmission) / (refl ? pr : 1.f - pr);
  s.delta = false;
  s.eta = 1.f;
  return true;
}

}  // namespace caustica
