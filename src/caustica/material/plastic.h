// Smooth plastic: a dielectric coat (Fresnel F, relative IOR eta) over a
// Lambertian base, as in Weidlich & Wilkie 2007 ("Arbitrarily layered
// micro-facet surfaces") reduced to a smooth coat, and Mitsuba's `plastic`:
//   specular: F(cos_o) * Ks, a delta lobe;
//   diffuse:  f_d = (1 - F(cos_i)) (1 - F(cos_o)) / eta^2 * Kd / (pi (1 - Kd Fdr_int)),
// where Fdr_int is the internal diffuse Fresnel reflectance (the hemispherical
// average of F seen from inside), which accounts for light bouncing between
// coat and base. f_d is symmetric in (wo, wi), so the BSDF is reciprocal.
#pragma once
#include "../base/sampling.h"
#include "fresnel.h"
#include "material.h"

namespace caustica {

CHD RGB plastic_diffuse_albedo(const Material& m) {
  return {m.diffuse.x / (1.f - m.diffuse.x * m.fdr_int), m.diffuse.y / (1.f - m.diffuse.y * m.fdr_int),
          m.diffuse.z / (1.f - m.diffuse.z * m.fdr_int)};
}
CHD float plastic_specular_prob(const Material& m, float Fo) {
  float ws = Fo * luminance(m.specular);
  float wd = (1.f - Fo) * luminance(m.diffuse);
  return ws + wd > 0.f ? ws / (ws + wd) : 1.f;
}
CHD RGB plastic_eval(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return RGB(0.f);
  float Fo = fresnel_dielectric(wo.z, m.eta), Fi = fresnel_dielectric(wi.z, m.eta);
  return plastic_diffuse_albedo(m) * ((1.f - Fo) * (1.f - Fi) / (m.eta * m.eta) * kInvPi);
}
CHD float plastic_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return 0.f;
  float ps = plastic_specular_prob(m, fresnel_dielectric(wo.z, m.eta));
  return (1.f - ps) * cosine_hemisphere_pdf(wi);
}
CHD bool plastic_sample(const Material& m, Vec3f wo, float uc, Vec2f u, BSDFSample& s) {
  if (wo.z <= 0.f) return false;
  float Fo = fresnel_dielectric(wo.z, m.eta);
  float ps = plastic_specular_prob(m, Fo);
  s.eta = 1.f;
  if (uc < ps) {
    s.wi = Vec3f(-wo.x, -wo.y, wo.z);
    s.pdf = ps;
    s.delta = true;
    s.weight = m.specular * (Fo / ps);
    return true;
  }
  s.wi = square_to_cosine_hemisphere(u);
  if (s.wi.z <= 0.f) return false;
  s.delta = false;
  s.pdf = (1.f - ps) * cosine_hemisphere_pdf(s.wi);
  s.weight = plastic_eval(m, wo, s.wi) * (s.wi.z / s.pdf);
  return s.pdf > 0.f;
}

}  // namespace caustica
