// glTF 2.0 metallic-roughness material (glTF 2.0 specification, Appendix B
// "BRDF Implementation"; KHR_materials_transmission and KHR_materials_ior) as
// a blend of three BSDFs with weights that sum to one:
//   metal        w_m = metallic:
//                GGX reflection (Walter et al. 2007 Eq. 20) with Schlick's
//                Fresnel, F0 = base colour (Schlick 1994, Eq. 24);
//   glass        w_t = (1 - metallic) * transmission:
//                the rough dielectric of rough_dielectric.h (Walter et al. 2007
//                Eqs. 20-21) with relative IOR `eta`, transmission tinted by
//                the base colour (KHR_materials_transmission);
//   dielectric   w_d = (1 - metallic) * (1 - transmission):
//                GGX reflection with the exact dielectric Fresnel F(eta) over
//                a diffuse base. glTF's base (Appendix B: fresnel_mix leaves
//                1 - F of the light to base/pi) with the Fresnel factor on
//                both sides, base/pi (1-F(cos_o))(1-F(cos_i)): reciprocal,
//                albedo <= 1, and within a few percent of the specification's
//                (1-F(v.h)) base/pi where that one is bounded. With
//                kPlasticBase, the plastic base of plastic.h instead:
//                base/pi (1-F(cos_o))(1-F(cos_i)) / (eta^2 (1 - base Fdr_int)),
//                the light refracted into a coat and reflected inside it
//                (Mitsuba's roughplastic; ~0.6 x as bright at base 0.5, eta 1.5).
// GGX alpha = roughness^2 (the glTF convention); with kBeckmann (Mitsuba's roughplastic) the Beckmann
// distribution instead (material/microfacet.h). Roughness alpha below
// kSmoothAlpha makes the specular lobes Dirac deltas (a GGX lobe that narrow
// is a mirror to float precision, and sampling it as a delta avoids the
// numerical trouble of D at tiny alpha).
// Sampling picks a component with probability equal to its weight (then, in
// the dielectric, specular with probability Fo / (Fo + (1-Fo) lum(base)));
// continuous samples are weighted by the full mixture f / pdf, delta samples
// by their own lobe.
#pragma once
#include "dielectric.h"
#include "microfacet.h"
#include "plastic.h"
#include "rough_dielectric.h"

namespace caustica {

constexpr float kSmoothAlpha = 1e-3f;

CHD RGB schlick_fresnel(RGB f0, float cos_i) {
  float c = clampf(1.f - cos_i, 0.f, 1.f);
  float c5 = c * c * c * c * c;
  return f0 + (RGB(1.f) - f0) * c5;
}

struct MRWeights {
  float metal, glass, dielectric;
};
CHD MRWeights mr_weights(const Material& m) {
  float metal = clampf(m.metallic, 0.f, 1.f);
  float tw = clampf(m.transmission_weight, 0.f, 1.f);
  return {metal, (1.f - metal) * tw, (1.f - metal) * (1.f - tw)};
}
CHD bool mr_smooth(const Material& m) { return m.alpha_x < kSmoothAlpha && m.alpha_y < kSmoothAlpha; }
CHD bool mr_is_delta(const Material& m) { return mr_smooth(m) && mr_weights(m).dielectric == 0.f; }
CHD Material mr_glass(const Material& m) {
  Material g = m;
  g.type = mr_smooth(m) ? MaterialType::kDielectric : MaterialType::kRoughDielectric;
  g.specular = RGB(1.f);
  g.transmission = m.diffuse;
  return g;
}
CHD float mr_specular_prob(const Material& m, float Fo) {
  float ws = Fo, wd = (1.f - Fo) * luminance(m.diffuse);
  return ws + wd > 0.f ? ws / (ws + wd) : 1.f;
}

// Continuous parts of f (delta lobes evaluate to zero), without the cosine.
CHD RGB metallic_roughness_eval(const Material& m, Vec3f wo, Vec3f wi, TransportMode mode) {
  MRWeights w = mr_weights(m);
  RGB f(0.f);
  if (w.glass > 0.f && !mr_smooth(m)) f += rough_dielectric_eval(mr_glass(m), wo, wi, mode) * w.glass;
  if (wo.z <= 0.f || wi.z <= 0.f) return f;
  if (!mr_smooth(m)) {
    Vec3f wm = normalize(wo + wi);
    Microfacet g = material_microfacet(m);
    float dg = g.D(wm) * g.G(wo, wi) / (4.f * wo.z * wi.z);
    float c = absdot(wo, wm);
    if (w.metal > 0.f) f += schlick_fresnel(m.diffuse, c) * (dg * w.metal);
    if (w.dielectric > 0.f) f += RGB(fresnel_dielectric(c, m.eta) * dg * w.dielectric);
  }
  if (w.dielectric > 0.f) {
    float Fo = fresnel_dielectric(wo.z, m.eta), Fi = fresnel_dielectric(wi.z, m.eta);
    RGB base = (m.flags & kPlasticBase) ? plastic_diffuse_albedo(m) / (m.eta * m.eta) : m.diffuse;
    f += base * ((1.f - Fo) * (1.f - Fi) * kInvPi * w.dielectric);
  }
  return f;
}

// Density of the continuous parts of the sampling mixture.
CHD float metallic_roughness_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  MRWeights w = mr_weights(m);
  float pdf = 0.f;
  // Seen from behind only the glass is sampled (selection probability 1).
  float sel_glass = wo.z <= 0.f ? 1.f : w.glass;
  if (w.glass > 0.f && !mr_smooth(m)) pdf += sel_glass * rough_dielectric_pdf(mr_glass(m), wo, wi);
  if (wo.z <= 0.f || wi.z <= 0.f) return pdf;
  float ps = mr_specular_prob(m, fresnel_dielectric(wo.z, m.eta));
  if (!mr_smooth(m)) {
    Vec3f wm = normalize(wo + wi);
    Microfacet g = material_microfacet(m);
    float p_refl = g.pdf_wm(wo, wm) / (4.f * absdot(wo, wm));
    pdf += (w.metal + w.dielectric * ps) * p_refl;
  }
  if (w.dielectric > 0.f) pdf += w.dielectric * (1.f - ps) * cosine_hemisphere_pdf(wi);
  return pdf;
}

CHD bool metallic_roughness_sample(const Material& m, Vec3f wo, float uc, Vec2f u, TransportMode mode,
                                   BSDFSample& s) {
  MRWeights w = mr_weights(m);
  bool smooth = mr_smooth(m);
  s.eta = 1.f;
  // Component choice; uc is rescaled so the chosen lobe can reuse it.
  if (uc < w.glass || wo.z <= 0.f) {
    if (w.glass == 0.f) return false;  // seen from behind: only the glass transmits
    float sel = wo.z <= 0.f ? 1.f : w.glass;
    float uc2 = wo.z <= 0.f ? uc : uc / w.glass;
    Material g = mr_glass(m);
    if (smooth) {
      if (!dielectric_sample(g, wo, minf(uc2, 0.99999994f), mode, s)) return false;
      s.pdf *= sel;
      s.weight = s.weight * (w.glass / sel);
      return true;
    }
    if (!rough_dielectric_sample(g, wo, minf(uc2, 0.99999994f), u, mode, s)) return false;
  } else {
    uc = (uc - w.glass) / (1.f - w.glass);
    float Fo = fresnel_dielectric(wo.z, m.eta);
    float ps = mr_specular_prob(m, Fo);
    float p_metal = w.metal / (w.metal + w.dielectric);
    bool metal = uc < p_metal;
    bool spec = metal || (uc - p_metal) / (1.f - p_metal) < ps;
    if (spec && smooth) {
      s.wi = Vec3f(-wo.x, -wo.y, wo.z);
      s.delta = true;
      if (metal) {
        s.pdf = w.metal;
        s.weight = schlick_fresnel(m.diffuse, wo.z);
      } else {
        s.pdf = w.dielectric * ps;
        s.weight = RGB(Fo / ps);
      }
      return true;
    }
    if (spec) {
      Microfacet g = material_microfacet(m);
      s.wi = reflect(wo, g.sample_wm(wo, u));
    } else {
      s.wi = square_to_cosine_hemisphere(u);
    }
    if (s.wi.z <= 0.f) return false;
    s.eta = 1.f;
  }
  s.delta = false;
  s.pdf = metallic_roughness_pdf(m, wo, s.wi);
  if (!(s.pdf > 0.f)) return false;
  s.weight = metallic_roughness_eval(m, wo, s.wi, mode) * (abs_cos_theta(s.wi) / s.pdf);
  return isfinite3(s.weight);
}

}  // namespace caustica
