// Mitsuba 3's `principled` BSDF: the Disney BSDF of Burley 2012 ("Physically Based Shading at Disney",
// SIGGRAPH course notes, Sec. 5 and Appendix B) extended to transmission as in Burley 2015 ("Extending the
// Disney BRDF to a BSDF with Integrated Subsurface Scattering", Sec. 3-4), with the lobes and weights Mitsuba 3
// gives it, so that a Mitsuba scene with principled materials renders here as it does there
// (docs/materials.md, "Principled").
//
// Parameters (Material): base colour `diffuse`, `metallic`, `transmission_weight` (spec_trans), `eta`, GGX
// alphas `alpha_x`/`alpha_y` (roughness^2, Mitsuba's anisotropic aspect already applied; floored at 0.001 here
// as Mitsuba floors them; the roughness the diffuse lobe uses is (alpha_x alpha_y)^(1/4), which recovers it
// whatever the aspect), `spec_tint`, `sheen`, `sheen_tint`, `flatness`, `clearcoat`, `clearcoat_gloss`.
// With brdf = (1 - metallic)(1 - spec_trans) and bsdf = (1 - metallic) spec_trans, seen from the front
// (wo.z > 0; wo towards the viewer, wi towards the light, h their half vector):
//   specular reflection   F_p D G / (4 |cos_o cos_i|), D GGX (Walter et al. 2007 Eq. 33), G = G1(wo) G1(wi)
//                         (the separable Smith term, Walter Eq. 23, as Mitsuba's principled has it), and
//                         F_p = (1 - metallic)(1 - spec_tint) F(wo.h) + metallic S(base, wo.h)
//                               + (1 - metallic) spec_tint S(tint R0(eta), wo.h),
//                         F the exact dielectric Fresnel, S Schlick's approximation (Schlick 1994 Eq. 24)
//                         from F0, R0(eta) = ((eta - 1) / (eta + 1))^2, tint = base / luminance(base);
//   specular transmission sqrt(base) bsdf (1 - F) x Walter et al. 2007's Eq. 21 with the same D and G
//                         (divided by eta^2 when radiance is carried, Veach 1997 Sec. 5.2);
//   diffuse               base brdf / pi [(1 - fl)(f_d + f_r) + fl f_ss] (Burley 2012 Sec. 5.3 and Burley
//                         2015 Sec. 3.2): f_d = (1 - F_L/2)(1 - F_V/2), F_x = (1 - cos_x)^5, retro-reflection
//                         f_r = R_R (F_L + F_V + F_L F_V (R_R - 1)), R_R = 2 roughness cos_d^2 (cos_d = wi.h),
//                         and the "flatness" lobe f_ss = 1.25 (F_ss (1 / (cos_o + cos_i) - 1/2) + 1/2),
//                         F_ss = (1 + (R_R/2 - 1) F_L)(1 + (R_R/2 - 1) F_V) (Hanrahan-Krueger-like);
//   sheen                 sheen (1 - metallic) (1 - cos_d)^5 lerp(1, tint, sheen_tint), where the diffuse
//                         lobe is (Burley 2012 Sec. 5.4; no 1/pi, as in Disney's and Mitsuba's code);
//   clearcoat             clearcoat / 4 x S(0.04, wo.h) D_GTR1(h) G_cc with GTR1's alpha = lerp(0.1, 0.001,
//                         clearcoat_gloss) (Burley 2012 Sec. 5.5, Appendix B.2) and G_cc the separable
//                         Smith GGX term of alpha 0.25; as in Disney's and Mitsuba's code, without the
//                         1 / (4 cos_o cos_i) of a microfacet model.
// Seen from behind (wo.z < 0, inside a transmissive material) only bsdf F D G / (4 |cos_o cos_i|) and the
// transmission remain. Schlick's S uses the transmitted cosine when the ray goes to the optically thinner side,
// as Mitsuba's does. This model does not conserve energy (the diffuse lobe is not darkened by the specular
// one); it is the reference's model, not a layered one (compare material/metallic_roughness.h).
//
// Sampling: with T = brdf + clearcoat / 4 + 1 (front; T = 1 from behind), the diffuse lobe (cosine-weighted)
// with probability brdf / T, the clearcoat's GTR1 normals (Burley 2012 Appendix B.2) with
// clearcoat / (4 T), else a GGX visible normal (Heitz 2018), refracted through it with probability
// bsdf (1 - F) (1 - F from behind) and reflected otherwise; the pdf is the whole mixture's.
#pragma once
#include "../base/sampling.h"
#include "fresnel.h"
#include "material.h"
#include "microfacet.h"

namespace caustica {

constexpr float kPrincipledMinAlpha = 1e-3f;  // Mitsuba's floor on the GGX alphas

struct PrincipledLobes {
  float brdf, bsdf;  // weights of the reflecting and the transmitting major lobes
  GGX ggx;
  float roughness;
};
CHD PrincipledLobes principled_lobes(const Material& m) {
  const float metal = clampf(m.metallic, 0.f, 1.f), st = clampf(m.transmission_weight, 0.f, 1.f);
  const float ax = maxf(m.alpha_x, kPrincipledMinAlpha), ay = maxf(m.alpha_y, kPrincipledMinAlpha);
  return {(1.f - metal) * (1.f - st), (1.f - metal) * st, GGX{ax, ay},
          std::sqrt(std::sqrt(maxf(m.alpha_x * m.alpha_y, 0.f)))};
}

// Schlick's weight at wo.h = c for a surface of relative index eta: the incident angle when the ray goes into
// the denser side, else the transmitted angle (1 beyond the critical angle).
CHD float principled_schlick(float c, float eta) {
  const float eta_it = c >= 0.f ? eta : 1.f / eta;
  if (eta_it > 1.f) return schlick_weight(std::fabs(c));
  const float eta_ti = 1.f / eta_it;
  return schlick_weight(safe_sqrt(1.f - (1.f - c * c) * eta_ti * eta_ti));
}
CHD RGB principled_tint(RGB base) {
  const float lum = luminance(base);
  return lum > 0.f ? base / lum : RGB(1.f);
}
// GTR1 (Burley 2012 Appendix B.2: the clearcoat's normal distribution, 0 < alpha < 1).
CHD float principled_gtr1(float cos_h, float alpha) {
  const float a2 = alpha * alpha;
  const float d = (a2 - 1.f) / (kPi * std::log(a2) * (1.f + (a2 - 1.f) * cos_h * cos_h));
  return d * cos_h > 1e-20f ? d : 0.f;
}
CHD float principled_clearcoat_alpha(const Material& m) {
  const float g = clampf(m.clearcoat_gloss, 0.f, 1.f);
  return 0.1f + (0.001f - 0.1f) * g;
}

// The geometry shared by eval and pdf: the half vector (generalised for refraction, Walter et al. 2007 Eq. 16,
// turned to +z), whether (wo, wi) is a reflection or a refraction, and whether h faces both directions the
// way that event needs.
struct PrincipledHalf {
  Vec3f h;
  float eta_path;  // eta seen by the ray: eta from the front, 1 / eta from behind
  bool reflect, refract, reflect_ok, refract_ok;
};
CHD PrincipledHalf principled_half(const Material& m, Vec3f wo, Vec3f wi) {
  PrincipledHalf r;
  r.reflect = wo.z * wi.z > 0.f;
  r.refract = wo.z * wi.z < 0.f;
  r.eta_path = wo.z > 0.f ? m.eta : 1.f / m.eta;
  Vec3f h = wo + wi * (r.reflect ? 1.f : r.eta_path);
  const float l2 = length_sq(h);
  r.h = l2 > 0.f ? h / std::sqrt(l2) : Vec3f(0.f, 0.f, 1.f);
  if (r.h.z < 0.f) r.h = -r.h;
  const Vec3f hs = wo.z >= 0.f ? r.h : -r.h;  // h on wo's side of the surface
  r.reflect_ok = l2 > 0.f && dot(wo, hs) > 0.f && dot(wi, hs) > 0.f;
  r.refract_ok = l2 > 0.f && dot(wo, hs) > 0.f && dot(wi, hs) < 0.f;
  return r;
}

// f(wo, wi) without the cosine.
CHD RGB principled_eval(const Material& m, Vec3f wo, Vec3f wi, TransportMode mode) {
  const float co = wo.z, ci = wi.z;
  if (co == 0.f) return RGB(0.f);
  const PrincipledLobes L = principled_lobes(m);
  const bool front = co > 0.f;
  if (!front && L.bsdf <= 0.f) return RGB(0.f);
  const PrincipledHalf H = principled_half(m, wo, wi);
  if (!H.reflect && !H.refract) return RGB(0.f);
  const float c_oh = dot(wo, H.h);
  const float F = fresnel_dielectric(c_oh, m.eta);
  const float metal = clampf(m.metallic, 0.f, 1.f);
  RGB f(0.f);
  if (H.reflect && H.reflect_ok && F > 0.f) {
    const float dg = L.ggx.D(H.h) * L.ggx.G1(wo) * L.ggx.G1(wi) / std::fabs(4.f * co * ci);
    RGB Fp;
    if (front) {
      const float tint_w = clampf(m.spec_tint, 0.f, 1.f);
      const float w = principled_schlick(c_oh, m.eta);
      Fp = RGB(F * (1.f - metal) * (1.f - tint_w));
      if (metal > 0.f) Fp += (m.diffuse + (RGB(1.f) - m.diffuse) * w) * metal;
      if (tint_w > 0.f) {
        const float eta_it = c_oh >= 0.f ? m.eta : 1.f / m.eta;
        const RGB f0 = principled_tint(m.diffuse) * sqr((eta_it - 1.f) / (eta_it + 1.f));
        Fp += (f0 + (RGB(1.f) - f0) * w) * ((1.f - metal) * tint_w);
      }
    } else {
      Fp = RGB(L.bsdf * F);
    }
    f += Fp * dg;
  }
  if (L.bsdf > 0.f && H.refract && H.refract_ok && F < 1.f) {
    const float c_ih = dot(wi, H.h), e = H.eta_path;
    float t = (1.f - F) * L.ggx.D(H.h) * L.ggx.G1(wo) * L.ggx.G1(wi) * e * e * c_oh * c_ih /
              (co * ci * sqr(c_oh + e * c_ih));
    if (mode == TransportMode::kRadiance) t /= e * e;
    const RGB root(std::sqrt(maxf(m.diffuse.x, 0.f)), std::sqrt(maxf(m.diffuse.y, 0.f)),
                   std::sqrt(maxf(m.diffuse.z, 0.f)));
    f += root * (L.bsdf * std::fabs(t));
  }
  if (!front || !H.reflect) return f;
  const float cc = clampf(m.clearcoat, 0.f, 1.f);
  if (cc > 0.f && H.reflect_ok) {
    const float Fcc = 0.04f + 0.96f * principled_schlick(c_oh, m.eta);
    const float Dcc = principled_gtr1(H.h.z, principled_clearcoat_alpha(m));
    const Microfacet gcc{0.25f, 0.25f, false};  // the clearcoat's masking: isotropic GGX of alpha 0.25
    const float Gcc = gcc.G1_facing(wo, H.h) * gcc.G1_facing(wi, H.h);
    f += RGB(0.25f * cc * Fcc * Dcc * Gcc);
  }
  if (L.brdf > 0.f) {
    const float Fv = schlick_weight(std::fabs(co)), Fl = schlick_weight(std::fabs(ci));
    const float cos_d = dot(H.h, wi);
    const float rr = 2.f * L.roughness * cos_d * cos_d;
    float d = (1.f - 0.5f * Fl) * (1.f - 0.5f * Fv) + rr * (Fl + Fv + Fl * Fv * (rr - 1.f));
    const float flat = clampf(m.flatness, 0.f, 1.f);
    if (flat > 0.f) {
      const float fss = (1.f + (0.5f * rr - 1.f) * Fl) * (1.f + (0.5f * rr - 1.f) * Fv);
      const float ss = 1.25f * (fss * (1.f / (std::fabs(co) + std::fabs(ci)) - 0.5f) + 0.5f);
      d = (1.f - flat) * d + flat * ss;
    }
    f += m.diffuse * (L.brdf * kInvPi * d);
    const float sheen = clampf(m.sheen, 0.f, 1.f);
    if (sheen > 0.f && metal < 1.f) {
      const float st = clampf(m.sheen_tint, 0.f, 1.f);
      const RGB c = RGB(1.f) + (principled_tint(m.diffuse) - RGB(1.f)) * st;
      f += c * (sheen * (1.f - metal) * schlick_weight(std::fabs(cos_d)));
    }
  }
  return f;
}

// The probabilities of bsdf_sample's first choice: diffuse, clearcoat (the rest: a GGX normal).
struct PrincipledChoice {
  float diffuse, clearcoat;
};
CHD PrincipledChoice principled_choice(const Material& m, const PrincipledLobes& L, bool front) {
  if (!front) return {0.f, 0.f};
  const float cc = 0.25f * clampf(m.clearcoat, 0.f, 1.f);
  const float t = L.brdf + cc + 1.f;
  return {L.brdf / t, cc / t};
}

CHD float principled_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  const float co = wo.z;
  if (co == 0.f) return 0.f;
  const PrincipledLobes L = principled_lobes(m);
  const bool front = co > 0.f;
  if (!front && L.bsdf <= 0.f) return 0.f;
  const PrincipledHalf H = principled_half(m, wo, wi);
  const PrincipledChoice P = principled_choice(m, L, front);
  const float p_ggx = 1.f - P.diffuse - P.clearcoat;
  const float c_oh = dot(wo, H.h);
  const float F = fresnel_dielectric(c_oh, m.eta);
  const float p_refract = front ? L.bsdf * (1.f - F) : 1.f - F;
  float pdf = 0.f;
  if (H.reflect && H.reflect_ok) pdf += p_ggx * (1.f - p_refract) * L.ggx.D_visible(wo, H.h) / (4.f * std::fabs(c_oh));
  if (H.refract && H.refract_ok && p_refract > 0.f) {
    const float c_ih = dot(wi, H.h), e = H.eta_path;
    pdf += p_ggx * p_refract * L.ggx.D_visible(wo, H.h) * std::fabs(c_ih) * e * e / sqr(c_oh + e * c_ih);
  }
  if (front && H.reflect) {
    pdf += P.diffuse * cosine_hemisphere_pdf(wi);
    if (P.clearcoat > 0.f && H.reflect_ok)
      pdf += P.clearcoat * principled_gtr1(H.h.z, principled_clearcoat_alpha(m)) * H.h.z / (4.f * std::fabs(c_oh));
  }
  return pdf;
}

CHD bool principled_sample(const Material& m, Vec3f wo, float uc, Vec2f u, TransportMode mode, BSDFSample& s) {
  const float co = wo.z;
  if (co == 0.f) return false;
  const PrincipledLobes L = principled_lobes(m);
  const bool front = co > 0.f;
  if (!front && L.bsdf <= 0.f) return false;
  const PrincipledChoice P = principled_choice(m, L, front);
  s.eta = 1.f;
  s.delta = false;
  if (uc < P.diffuse) {
    s.wi = square_to_cosine_hemisphere(u);
  } else if (uc < P.diffuse + P.clearcoat) {
    // GTR1 normal: cos^2 theta = (1 - a^(2 (1 - u))) / (1 - a^2), uniform in phi.
    const float a2 = sqr(principled_clearcoat_alpha(m));
    const float c2 = (1.f - std::pow(a2, 1.f - u.y)) / (1.f - a2);
    const float ct = std::sqrt(clampf(c2, 0.f, 1.f)), st = safe_sqrt(1.f - ct * ct), phi = 2.f * kPi * u.x;
    const Vec3f h(st * std::cos(phi), st * std::sin(phi), ct);
    if (dot(wo, h) <= 0.f) return false;  // wo sees the back of this normal (as Mitsuba, such samples are void)
    s.wi = reflect(wo, h);
    if (s.wi.z <= 0.f) return false;
  } else {
    const float rest = 1.f - P.diffuse - P.clearcoat;
    const float uc2 = minf((uc - P.diffuse - P.clearcoat) / rest, 0.99999994f);
    const Vec3f h = L.ggx.sample_wm(front ? wo : -wo, u);
    const float c_oh = dot(wo, h);
    const float F = fresnel_dielectric(c_oh, m.eta);
    const float p_refract = front ? L.bsdf * (1.f - F) : 1.f - F;
    if (uc2 < p_refract) {
      const float etap = c_oh > 0.f ? m.eta : 1.f / m.eta;
      if (!refract(wo, c_oh > 0.f ? h : -h, etap, s.wi)) return false;
      if (s.wi.z * wo.z >= 0.f) return false;
      s.eta = etap;
    } else {
      s.wi = reflect(wo, h);
      if (s.wi.z * wo.z <= 0.f) return false;
    }
  }
  s.pdf = principled_pdf(m, wo, s.wi);
  if (!(s.pdf > 0.f)) return false;
  s.weight = principled_eval(m, wo, s.wi, mode) * (std::fabs(s.wi.z) / s.pdf);
  return isfinite3(s.weight);
}

}  // namespace caustica
