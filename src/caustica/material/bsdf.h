// Dispatch over the material tag, and the one-/two-sided convention:
// reflective materials are black when seen from behind unless kTwoSided, in
// which case they are evaluated as if seen from the front. Transmissive
// materials are always evaluated on both sides.
#pragma once
#include "conductor.h"
#include "dielectric.h"
#include "diffuse.h"
#include "diffuse_transmission.h"
#include "metallic_roughness.h"
#include "phong.h"
#include "plastic.h"
#include "principled.h"
#include "rough_plastic.h"
#include "rough_conductor.h"
#include "rough_dielectric.h"
#include "thin_dielectric.h"

namespace caustica {

// Flip to the front side for two-sided reflective materials; returns the sign applied.
CHD float bsdf_side(const Material& m, Vec3f& wo) {
  if (wo.z < 0.f && (m.flags & kTwoSided) && !material_is_transmissive(m)) {
    wo.z = -wo.z;
    return -1.f;
  }
  return 1.f;
}

// f(wo, wi), without the cosine. Delta lobes evaluate to zero.
CHD RGB bsdf_eval(const Material& m, Vec3f wo, Vec3f wi, TransportMode mode = TransportMode::kRadiance) {
  float side = bsdf_side(m, wo);
  wi.z *= side;
  switch (m.type) {
    case MaterialType::kDiffuse: return diffuse_eval(m, wo, wi);
    case MaterialType::kRoughConductor: return rough_conductor_eval(m, wo, wi);
    case MaterialType::kRoughDielectric: return rough_dielectric_eval(m, wo, wi, mode);
    case MaterialType::kPlastic: return plastic_eval(m, wo, wi);
    case MaterialType::kDiffuseTransmission: return difftrans_eval(m, wo, wi);
    case MaterialType::kPhong: return phong_eval(m, wo, wi);
    case MaterialType::kMetallicRoughness: return metallic_roughness_eval(m, wo, wi, mode);
    case MaterialType::kPrincipled: return principled_eval(m, wo, wi, mode);
    case MaterialType::kRoughPlastic: return rough_plastic_eval(m, wo, wi);
    default: return RGB(0.f);
  }
}

// Solid-angle density of bsdf_sample producing wi (its non-delta part).
CHD float bsdf_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  float side = bsdf_side(m, wo);
  wi.z *= side;
  switch (m.type) {
    case MaterialType::kDiffuse: return diffuse_pdf(m, wo, wi);
    case MaterialType::kRoughConductor: return rough_conductor_pdf(m, wo, wi);
    case MaterialType::kRoughDielectric: return rough_dielectric_pdf(m, wo, wi);
    case MaterialType::kPlastic: return plastic_pdf(m, wo, wi);
    case MaterialType::kDiffuseTransmission: return difftrans_pdf(m, wo, wi);
    case MaterialType::kPhong: return phong_pdf(m, wo, wi);
    case MaterialType::kMetallicRoughness: return metallic_roughness_pdf(m, wo, wi);
    case MaterialType::kPrincipled: return principled_pdf(m, wo, wi);
    case MaterialType::kRoughPlastic: return rough_plastic_pdf(m, wo, wi);
    default: return 0.f;
  }
}

// Samples wi given wo; uc chooses the lobe, u the direction.
CHD bool bsdf_sample(const Material& m, Vec3f wo, float uc, Vec2f u, BSDFSample& s,
                     TransportMode mode = TransportMode::kRadiance) {
  float side = bsdf_side(m, wo);
  bool ok = false;
  s.eta = 1.f;
  switch (m.type) {
    case MaterialType::kDiffuse: ok = diffuse_sample(m, wo, u, s); break;
    case MaterialType::kConductor: ok = conductor_sample(m, wo, s); break;
    case MaterialType::kRoughConductor: ok = rough_conductor_sample(m, wo, u, s); break;
    case MaterialType::kDielectric: ok = dielectric_sample(m, wo, uc, mode, s); break;
    case MaterialType::kRoughDielectric: ok = rough_dielectric_sample(m, wo, uc, u, mode, s); break;
    case MaterialType::kThinDielectric: ok = thin_dielectric_sample(m, wo, uc, s); break;
    case MaterialType::kPlastic: ok = plastic_sample(m, wo, uc, u, s); break;
    case MaterialType::kDiffuseTransmission: ok = difftrans_sample(m, wo, uc, u, s); break;
    case MaterialType::kPhong: ok = phong_sample(m, wo, uc, u, s); break;
    case MaterialType::kMetallicRoughness: ok = metallic_roughness_sample(m, wo, uc, u, mode, s); break;
    case MaterialType::kPrincipled: ok = principled_sample(m, wo, uc, u, mode, s); break;
    case MaterialType::kRoughPlastic: ok = rough_plastic_sample(m, wo, uc, u, s); break;
    default: break;
  }
  s.wi.z *= side;
  return ok && s.pdf > 0.f && isfinite3(s.weight);
}

}  // namespace caustica
