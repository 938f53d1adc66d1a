// The GGX / Trowbridge-Reitz microfacet distribution with Smith masking.
// D: Walter et al. 2007, "Microfacet Models for Refraction through Rough
// Surfaces", Eq. 33 (anisotropic form: Heitz 2014, "Understanding the
// Masking-Shadowing Function", Eq. 85); Lambda: Heitz 2014 Eq. 86; the
// height-correlated G2 = 1 / (1 + Lambda(wo) + Lambda(wi)) (Heitz 2014 Eq. 99).
// Visible normals: Heitz 2018, "Sampling the GGX Distribution of Visible
// Normals", JCGT 7(4), Listing 1, with density D_wo(wm) = G1(wo) |wo.wm| D(wm) / |wo.z| (Eq. 2).
// Beckmann (Mitsuba's default for its rough BSDFs): D = exp(-tan^2 theta_m (cos^2 phi / ax^2 + sin^2 phi /
// ay^2)) / (pi ax ay cos^4 theta_m) (Walter et al. 2007 Eq. 25; its anisotropic form and Lambda as in Heitz 2014); its
// Lambda(a) = (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)), a = 1 / (alpha(phi) tan theta), so that
// 1 / (1 + Lambda) is Walter et al. 2007's exact Beckmann G1; sampled in proportion to D(wm) cos theta_m
// (Walter et al. 2007 Eqs. 28-29, the anisotropic phi as pbrt-v3's BeckmannDistribution::Sample_wh).
#pragma once
#include "../base/math.h"
#include "../base/sampling.h"
#include "material.h"

namespace caustica {

// What both distributions' D and Lambda are made of. For a normal wm: e = tan^2 theta (cos^2 phi / ax^2 +
// sin^2 phi / ay^2) and cos^4 theta (false where D vanishes: a horizontal normal). For a direction w:
// alpha(phi)^2 tan^2 theta, alpha(phi)^2 = cos^2 phi ax^2 + sin^2 phi ay^2 (false for an infinite tangent).
CHD bool microfacet_slope(Vec3f wm, float ax, float ay, float& e, float& c4) {
  const float t2 = tan2_theta(wm);
  if (!std::isfinite(t2)) return false;
  c4 = sqr(cos2_theta(wm));
  if (c4 < 1e-16f) return false;
  const float s2 = sin2_theta(wm);
  const float cos2_phi = s2 > 0.f ? wm.x * wm.x / s2 : 1.f;
  const float sin2_phi = s2 > 0.f ? wm.y * wm.y / s2 : 0.f;
  e = t2 * (cos2_phi / (ax * ax) + sin2_phi / (ay * ay));
  return true;
}
CHD bool microfacet_alpha_tan2(Vec3f w, float ax, float ay, float& at2) {
  const float t2 = tan2_theta(w);
  if (!std::isfinite(t2)) return false;
  const float s2 = sin2_theta(w);
  const float cos2_phi = s2 > 0.f ? w.x * w.x / s2 : 1.f;
  const float sin2_phi = s2 > 0.f ? w.y * w.y / s2 : 0.f;
  at2 = (cos2_phi * ax * ax + sin2_phi * ay * ay) * t2;
  return true;
}

struct GGX {
  float ax, ay;

  CHD float D(Vec3f wm) const {
    float e, c4;
    if (!microfacet_slope(wm, ax, ay, e, c4)) return 0.f;
    return 1.f / (kPi * ax * ay * c4 * sqr(1.f + e));
  }
  CHD float lambda(Vec3f w) const {
    float at2;
    if (!microfacet_alpha_tan2(w, ax, ay, at2)) return 0.f;
    return (std::sqrt(1.f + at2) - 1.f) * 0.5f;
  }
  CHD float G1(Vec3f w) const { return 1.f / (1.f + lambda(w)); }
  CHD float G(Vec3f wo, Vec3f wi) const { return 1.f / (1.f + lambda(wo) + lambda(wi)); }
  // Density of visible normals seen from w (Heitz 2018 Eq. 2).
  CHD float D_visible(Vec3f w, Vec3f wm) const {
    float c = abs_cos_theta(w);
    if (c == 0.f) return 0.f;
    return G1(w) / c * D(wm) * absdot(w, wm);
  }
  // Samples a visible normal for w (Heitz 2018, Sec. 3 / Listing 1).
  CHD Vec3f sample_wm(Vec3f w, Vec2f u) const {
    Vec3f wh = normalize(Vec3f(ax * w.x, ay * w.y, w.z));
    if (wh.z < 0.f) wh = -wh;
    // Orthonormal basis around wh (T1 perpendicular to z).
    float lensq = wh.x * wh.x + wh.y * wh.y;
    Vec3f T1 = lensq > 0.f ? Vec3f(-wh.y, wh.x, 0.f) / std::sqrt(lensq) : Vec3f(1.f, 0.f, 0.f);
    Vec3f T2 = cross(wh, T1);
    Vec2f p = square_to_concentric_disk(u);
    float h = std::sqrt(1.f - p.x * p.x);
    float s = 0.5f * (1.f + wh.z);
    p.y = (1.f - s) * h + s * p.y;
    float pz = safe_sqrt(1.f - p.x * p.x - p.y * p.y);
    Vec3f nh = T1 * p.x + T2 * p.y + wh * pz;
    return normalize(Vec3f(ax * nh.x, ay * nh.y, maxf(1e-6f, nh.z)));
  }
};

struct Beckmann {
  float ax, ay;

  CHD float D(Vec3f wm) const {
    float e, c4;
    if (!microfacet_slope(wm, ax, ay, e, c4)) return 0.f;
    return std::exp(-e) / (kPi * ax * ay * c4);
  }
  CHD float lambda(Vec3f w) const {
    float at2;
    if (!microfacet_alpha_tan2(w, ax, ay, at2) || at2 == 0.f) return 0.f;
    const float a = 1.f / std::sqrt(at2);
    return 0.5f * (std::erf(a) - 1.f) + std::exp(-a * a) / (2.f * a * 1.7724538509055160f);
  }
  // A normal with density D(wm) cos theta_m (in the +z hemisphere).
  CHD Vec3f sample_wm(Vec2f u) const {
    float log_u = std::log(maxf(1.f - u.x, 1e-30f));
    float phi, cos_phi, sin_phi;
    if (ax == ay) {
      phi = 2.f * kPi * u.y;
      cos_phi = std::cos(phi);
      sin_phi = std::sin(phi);
    } else {
      phi = std::atan(ay / ax * std::tan(2.f * kPi * u.y + 0.5f * kPi));
      if (u.y > 0.5f) phi += kPi;
      cos_phi = std::cos(phi);
      sin_phi = std::sin(phi);
    }
    float t2 = -log_u / (cos_phi * cos_phi / (ax * ax) + sin_phi * sin_phi / (ay * ay));
    float c = 1.f / std::sqrt(1.f + t2), s = safe_sqrt(1.f - c * c);
    return Vec3f(s * cos_phi, s * sin_phi, c);
  }
};

// The rough conductor's and rough dielectric's distribution: GGX, or Beckmann with kBeckmann. Masking is the
// height-correlated G2 = 1 / (1 + Lambda(wo) + Lambda(wi)) for both. sample_wm and pdf_wm: GGX's visible
// normals seen from w; Beckmann's D(wm) cos theta_m (then a normal that w sees from behind is discarded by the
// caller, which the density of the kept normals does not change).
struct Microfacet {
  float ax, ay;
  bool beckmann;

  CHD float D(Vec3f wm) const { return beckmann ? Beckmann{ax, ay}.D(wm) : GGX{ax, ay}.D(wm); }
  CHD float lambda(Vec3f w) const { return beckmann ? Beckmann{ax, ay}.lambda(w) : GGX{ax, ay}.lambda(w); }
  CHD float G1(Vec3f w) const { return 1.f / (1.f + lambda(w)); }
  // G1 with the sidedness Smith's masking needs: 0 where w sees the back of the microfacet wm.
  CHD float G1_facing(Vec3f w, Vec3f wm) const { return dot(w, wm) * w.z > 0.f ? G1(w) : 0.f; }
  CHD float G(Vec3f wo, Vec3f wi) const { return 1.f / (1.f + lambda(wo) + lambda(wi)); }
  // Density of the normals visible from w (Heitz 2018 Eq. 2), whichever the sampler.
  CHD float D_visible(Vec3f w, Vec3f wm) const {
    const float c = abs_cos_theta(w);
    return c > 0.f ? G1(w) / c * D(wm) * maxf(0.f, dot(w, wm)) : 0.f;
  }
  CHD float pdf_wm(Vec3f w, Vec3f wm) const {
    return beckmann ? Beckmann{ax, ay}.D(wm) * std::fabs(wm.z) : GGX{ax, ay}.D_visible(w, wm);
  }
  CHD Vec3f sample_wm(Vec3f w, Vec2f u) const {
    return beckmann ? Beckmann{ax, ay}.sample_wm(u) : GGX{ax, ay}.sample_wm(w, u);
  }
};
CHD Microfacet material_microfacet(const Material& m) {
  return Microfacet{m.alpha_x, m.alpha_y, (m.flags & kBeckmann) != 0u};
}

}  // namespace caustica
