// Rough dielectric (Walter et al. 2007, "Microfacet Models for Refraction
// through Rough Surfaces"): reflection f_r = F D G / (4 |cos_i cos_o|) (Eq. 20),
// transmission f_t = |wi.wm||wo.wm| / (|cos_i||cos_o|) * eta_t^2 (1 - F) D G /
// (eta_i (wi.wm) + eta_t (wo.wm))^2 (Eq. 21), generalised half vector (Eq. 16),
// Jacobian of refraction (Eq. 17). Normals are sampled from the visible-normal
// density (Heitz 2018; Beckmann's with kBeckmann, in proportion to D cos, material/microfacet.h) and the lobe
// is chosen with probability F.
// Radiance mode divides f_t by eta^2 (the non-symmetric BSDF, Veach 1997 Sec. 5.2).
#pragma once
#include "dielectric.h"
#include "fresnel.h"
#include "material.h"
#include "microfacet.h"

namespace caustica {

// Generalised half vector for (wo, wi), oriented to +z; false if degenerate
// or if a microfacet faces away from wo or wi.
CHD bool rough_dielectric_half(float eta, Vec3f wo, Vec3f wi, Vec3f& wm, float& etap, bool& refl) {
  if (wo.z == 0.f || wi.z == 0.f) return false;
  refl = wo.z * wi.z > 0.f;
  etap = refl ? 1.f : (wo.z > 0.f ? eta : 1.f / eta);
  wm = wi * etap + wo;
  if (length_sq(wm) == 0.f) return false;
  wm = normalize(wm);
  if (wm.z < 0.f) wm = -wm;
  if (dot(wm, wi) * wi.z < 0.f || dot(wm, wo) * wo.z < 0.f) return false;
  return true;
}

// The rough dielectric of parameters d and microfacets g (a Material's: the overloads below).
CHD RGB rough_dielectric_eval(const DielectricParams& d, const Microfacet& g, Vec3f wo, Vec3f wi,
                              TransportMode mode) {
  Vec3f wm;
  float etap;
  bool refl;
  if (!rough_dielectric_half(d.eta, wo, wi, wm, etap, refl)) return RGB(0.f);
  float F = fresnel_dielectric(dot(wo, wm), d.eta);
  if (refl) return d.reflect * (g.D(wm) * g.G(wo, wi) * F / std::fabs(4.f * wi.z * wo.z));
  float denom = sqr(dot(wi, wm) + dot(wo, wm) / etap) * wi.z * wo.z;
  float ft = g.D(wm) * (1.f - F) * g.G(wo, wi) * std::fabs(dot(wi, wm) * dot(wo, wm) / denom);
  if (mode == TransportMode::kRadiance) ft /= etap * etap;
  return d.transmit * ft;
}

CHD float rough_dielectric_pdf(const DielectricParams& d, const Microfacet& g, Vec3f wo, Vec3f wi) {
  Vec3f wm;
  float etap;
  bool refl;
  if (!rough_dielectric_half(d.eta, wo, wi, wm, etap, refl)) return 0.f;
  float F = fresnel_dielectric(dot(wo, wm), d.eta);
  if (refl) return g.pdf_wm(wo, wm) / (4.f * absdot(wo, wm)) * F;
  float denom = sqr(dot(wi, wm) + dot(wo, wm) / etap);
  return g.pdf_wm(wo, wm) * absdot(wi, wm) / denom * (1.f - F);
}

CHD bool rough_dielectric_sample(const DielectricParams& d, const Microfacet& g, Vec3f wo, float uc, Vec2f u,
                                 TransportMode mode, BSDFSample& s) {
  if (wo.z == 0.f) return false;
  // D_visible(wo, wm) = D_visible(-wo, wm) for normals in the +z hemisphere, so
  // from below the surface the visible normals of -wo are sampled.
  Vec3f wm = g.sample_wm(wo.z < 0.f ? -wo : wo, u);
  float cos_om = dot(wo, wm);
  if (cos_om * wo.z <= 0.f) return false;  // a Beckmann normal wo sees from behind (never a visible normal)
  float F = fresnel_dielectric(cos_om, d.eta);
  s.delta = false;
  if (uc < F) {
    s.wi = reflect(wo, wm);
    if (!same_hemisphere(wo, s.wi)) return false;
    s.eta = 1.f;
  } else {
    float etap = cos_om > 0.f ? d.eta : 1.f / d.eta;
    Vec3f n = cos_om > 0.f ? wm : -wm;
    if (!refract(wo, n, etap, s.wi)) return false;
    if (same_hemisphere(wo, s.wi) || s.wi.z == 0.f) return false;
    s.eta = etap;
  }
  s.pdf = rough_dielectric_pdf(d, g, wo, s.wi);
  if (!(s.pdf > 0.f)) return false;
  RGB f = rough_dielectric_eval(d, g, wo, s.wi, mode);
  s.weight = f * (abs_cos_theta(s.wi) / s.pdf);
  return isfinite3(s.weight);
}

CHD RGB rough_dielectric_eval(const Material& m, Vec3f wo, Vec3f wi, TransportMode mode) {
  return rough_dielectric_eval(dielectric_params(m), material_microfacet(m), wo, wi, mode);
}
CHD float rough_dielectric_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  return rough_dielectric_pdf(dielectric_params(m), material_microfacet(m), wo, wi);
}
CHD bool rough_dielectric_sample(const Material& m, Vec3f wo, float uc, Vec2f u, TransportMode mode,
                                 BSDFSample& s) {
  return rough_dielectric_sample(dielectric_params(m), material_microfacet(m), wo, uc, u, mode, s);
}

}  // namespace caustica
