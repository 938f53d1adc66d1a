// Rough plastic: a rough dielectric coat (GGX, or Beckmann with kBeckmann; relative IOR eta) over a Lambertian
// base, as Mitsuba 3's `roughplastic` defines it (itself after Weidlich & Wilkie 2007, "Arbitrarily layered
// micro-facet surfaces", with the coat's transmittance precomputed):
//   specular: Ks F(wo.h) D G / (4 cos_o cos_i) (Walter et al. 2007 Eq. 20, G the height-correlated Smith G2);
//   diffuse:  Kd / (1 - Kd R_int) t(cos_o) t(cos_i) / (pi eta^2),
// where t(mu) = 1 - R(mu) is the light the rough coat lets through at incidence cos mu (R its specular lobe's
// albedo) and R_int the hemispherical average of its reflectance seen from inside (relative IOR 1 / eta). Both
// are computed for each material when the scene is built (scene.cpp, prepare_rough_plastic: R by a 64 x 64
// quadrature of the lobe's own sampling weight over the unit square, at 32 cosines, so t holds the energy the
// specular lobe does not take) and t is stored in the material as 16-bit fractions, read with linear
// interpolation in cos. f is symmetric in (wo, wi), so the BSDF is reciprocal. Sampling: the coat's lobe with
// probability (1 - t(cos_o)) lum(Ks) / ((1 - t(cos_o)) lum(Ks) + t(cos_o) lum(Kd)), else cosine-weighted.
#pragma once
#include "../base/sampling.h"
#include "fresnel.h"
#include "material.h"
#include "microfacet.h"

namespace caustica {

// t(mu) from the material's table.
CHD float rough_plastic_t(const Material& m, float mu) { return material_table(m, mu); }
CHD float rough_plastic_specular_prob(const Material& m, float t_o) {
  const float ws = (1.f - t_o) * luminance(m.specular), wd = t_o * luminance(m.diffuse);
  return ws + wd > 0.f ? ws / (ws + wd) : 1.f;
}
// The coat's lobe alone (Ks F D G / (4 cos_o cos_i)).
CHD RGB rough_plastic_specular(const Material& m, Vec3f wo, Vec3f wi) {
  Vec3f h = wo + wi;
  if (length_sq(h) == 0.f) return RGB(0.f);
  h = normalize(h);
  const Microfacet g = material_microfacet(m);
  return m.specular * (fresnel_dielectric(dot(wo, h), m.eta) * g.D(h) * g.G(wo, wi) / (4.f * wo.z * wi.z));
}
CHD RGB rough_plastic_eval(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return RGB(0.f);
  const RGB base(m.diffuse.x / (1.f - m.diffuse.x * m.fdr_int), m.diffuse.y / (1.f - m.diffuse.y * m.fdr_int),
                 m.diffuse.z / (1.f - m.diffuse.z * m.fdr_int));
  const float t = rough_plastic_t(m, wo.z) * rough_plastic_t(m, wi.z) / (m.eta * m.eta) * kInvPi;
  return rough_plastic_specular(m, wo, wi) + base * t;
}
CHD float rough_plastic_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return 0.f;
  const float ps = rough_plastic_specular_prob(m, rough_plastic_t(m, wo.z));
  Vec3f h = wo + wi;
  float p = (1.f - ps) * cosine_hemisphere_pdf(wi);
  if (length_sq(h) > 0.f) {
    h = normalize(h);
    p += ps * material_microfacet(m).pdf_wm(wo, h) / (4.f * absdot(wo, h));
  }
  return p;
}
CHD bool rough_plastic_sample(const Material& m, Vec3f wo, float uc, Vec2f u, BSDFSample& s) {
  if (wo.z <= 0.f) return false;
  const float ps = rough_plastic_specular_prob(m, rough_plastic_t(m, wo.z));
  s.eta = 1.f;
  s.delta = false;
  if (uc < ps) {
    s.wi = reflect(wo, material_microfacet(m).sample_wm(wo, u));
  } else {
    s.wi = square_to_cosine_hemisphere(u);
  }
  if (s.wi.z <= 0.f) return false;
  s.pdf = rough_plastic_pdf(m, wo, s.wi);
  if (!(s.pdf > 0.f)) return false;
  s.weight = rough_plastic_eval(m, wo, s.wi) * (s.wi.z / s.pdf);
  return isfinite3(s.weight);
}

}  // namespace caustica
