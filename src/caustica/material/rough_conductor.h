// Rough conductor (Cook & Torrance 1982 with GGX or Beckmann): f = D G F / (4 cos_o cos_i),
// Walter et al. 2007 Eq. 20; sampled with GGX's visible normals (Heitz 2018), or Beckmann's D cos, whose
// reflected density is pdf_wm / (4 |wo.wm|) (Walter et al. 2007 Eq. 14).
#pragma once
#include "conductor.h"
#include "microfacet.h"

namespace caustica {

CHD RGB rough_conductor_eval(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return RGB(0.f);
  Vec3f wm = wo + wi;
  if (length_sq(wm) == 0.f) return RGB(0.f);
  wm = normalize(wm);
  Microfacet g = material_microfacet(m);
  RGB F = conductor_fresnel(m, absdot(wo, wm));
  return F * (g.D(wm) * g.G(wo, wi) / (4.f * wo.z * wi.z));
}
CHD float rough_conductor_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return 0.f;
  Vec3f wm = wo + wi;
  if (length_sq(wm) == 0.f) return 0.f;
  wm = normalize(wm);
  return material_microfacet(m).pdf_wm(wo, wm) / (4.f * absdot(wo, wm));
}
CHD bool rough_conductor_sample(const Material& m, Vec3f wo, Vec2f u, BSDFSample& s) {
  if (wo.z <= 0.f) return false;
  Microfacet g = material_microfacet(m);
  Vec3f wm = g.sample_wm(wo, u);
  s.wi = reflect(wo, wm);
  if (s.wi.z <= 0.f) return false;
  s.pdf = g.pdf_wm(wo, wm) / (4.f * absdot(wo, wm));
  if (!(s.pdf > 0.f)) return false;
  s.delta = false;
  // With visible normals f cos / pdf simplifies to F G2 / G1(wo) (Heitz 2018, Sec. 2); with Beckmann's D cos
  // sampling it is F G2 |wo.wm| / (wo.z wm.z).
  const float ratio = g.beckmann ? g.G(wo, s.wi) * absdot(wo, wm) / (wo.z * wm.z) : g.G(wo, s.wi) / g.G1(wo);
  s.weight = conductor_fresnel(m, absdot(wo, wm)) * ratio;
  return isfinite3(s.weight);
}

}  // namespace caustica
