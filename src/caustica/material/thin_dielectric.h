// Thin dielectric slab (a window pane): light reflects with the total
// reflectance of the two interfaces summed over internal bounces,
// R' = R + T^2 R / (1 - R^2) (pbrt-v4 Sec. 9.5.3 / Mitsuba's thindielectric),
// and is otherwise transmitted along -wo, undeviated.
#pragma once
#include "fresnel.h"
#include "material.h"

namespace caustica {

CHD float thin_dielectric_reflectance(float cos_o, float eta) {
  float R = fresnel_dielectric(std::fabs(cos_o), eta);
  float T = 1.f - R;
  if (R < 1.f) R += T * T * R / (1.f - R * R);
  return R;
}

CHD bool thin_dielectric_sample(const Material& m, Vec3f wo, float u, BSDFSample& s) {
  float R = thin_dielectric_reflectance(wo.z, m.eta);
  s.delta = true;
  s.eta = 1.f;
  if (u < R) {
    s.wi = Vec3f(-wo.x, -wo.y, wo.z);
    s.pdf = R;
    s.weight = m.specular;
  } else {
    s.wi = -wo;
    s.pdf = 1.f - R;
    s.weight = m.transmission;
  }
  return s.pdf > 0.f;
}

}  // namespace caustica
