// The GGX / Trowbridge-Reitz microfacet distribution with Smith masking.
// D: Walter et al. 2007, "Microfacet Models for Refraction through Rough
// Surfaces", Eq. 33 (anisotropic form: Heitz 2014, "Understanding the
// Masking-Shadowing Function", Eq. 85); Lambda: Heitz 2014 Eq. 86; the
// height-correlated G2 = 1 / (1 + Lambda(wo) + Lambda(wi)) (Heitz 2014 Eq. 99).
// Visible normals: Heitz 2018, "Sampling the GGX Distribution of Visible
// Normals", JCGT 7(4), Listing 1, with density D_wo(wm) = G1(wo) |wo.wm| D(wm) / |wo.z| (Eq. 2).
#pragma once
#include "../base/math.h"
#include "../base/sampling.h"

namespace caustica {

struct GGX {
  float ax, ay;

  CHD float D(Vec3f wm) const {
    float t2 = tan2_theta(wm);
    if (!std::isfinite(t2)) return 0.f;
    float c4 = sqr(cos2_theta(wm));
    if (c4 < 1e-16f) return 0.f;
    float s2 = sin2_theta(wm);
    float cos2_phi = s2 > 0.f ? wm.x * wm.x / s2 : 1.f;
    float sin2_phi = s2 > 0.f ? wm.y * wm.y / s2 : 0.f;
    float e = t2 * (cos2_phi / (ax * ax) + sin2_phi / (ay * ay));
    return 1.f / (kPi * ax * ay * c4 * sqr(1.f + e));
  }
  CHD float lambda(Vec3f w) const {
    float t2 = tan2_theta(w);
    if (!std::isfinite(t2)) return 0.f;
    float s2 = sin2_theta(w);
    float cos2_phi = s2 > 0.f ? w.x * w.x / s2 : 1.f;
    float sin2_phi = s2 > 0.f ? w.y * w.y / s2 : 0.f;
    float alpha2 = cos2_phi * ax * ax + sin2_phi * ay * ay;
    return (std::sqrt(1.f + alpha2 * t2) - 1.f) * 0.5f;
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

}  // namespace caustica
