// Smooth conductor: perfect mirror reflection weighted by the conductor
// Fresnel term (complex IOR, fresnel.h) times a tint, or by the tint alone.
#pragma once
#include "fresnel.h"
#include "material.h"

namespace caustica {

CHD RGB conductor_fresnel(const Material& m, float cos_i) {
  if (m.flags & kConductorTint) return m.specular;
  return m.specular * fresnel_conductor(cos_i, m.eta_c, m.k_c);
}

CHD bool conductor_sample(const Material& m, Vec3f wo, BSDFSample& s) {
  if (wo.z <= 0.f) return false;
  s.wi = Vec3f(-wo.x, -wo.y, wo.z);
  s.pdf = 1.f;
  s.delta = true;
  s.weight = conductor_fresnel(m, wo.z);
  return true;
}

}  // namespace caustica
