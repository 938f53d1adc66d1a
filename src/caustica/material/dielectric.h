// Smooth dielectric: specular reflection with probability F and refraction
// with probability 1 - F (exact unpolarised Fresnel, fresnel.h), total
// internal reflection, and the 1/eta^2 scaling of refracted radiance
// (Veach 1997, Eq. 5.14). m.eta = eta_inside / eta_outside; wo.z < 0 is inside.
#pragma once
#include "fresnel.h"
#include "material.h"

namespace caustica {

// What a dielectric interface (smooth here, rough in rough_dielectric.h) reads of its material: the IOR and the
// tints of its reflection and transmission. The metallic-roughness glass lobe passes its own (base colour as the
// transmission tint) instead of a modified copy of the whole Material (material/metallic_roughness.h).
struct DielectricParams {
  float eta;     // interior IOR over exterior IOR
  RGB reflect;   // reflection tint (Material::specular)
  RGB transmit;  // transmission tint (Material::transmission)
};
CHD DielectricParams dielectric_params(const Material& m) { return {m.eta, m.specular, m.transmission}; }

CHD bool dielectric_sample(const DielectricParams& d, Vec3f wo, float u, TransportMode mode, BSDFSample& s) {
  float F = fresnel_dielectric(wo.z, d.eta);
  s.delta = true;
  if (u < F) {
    s.wi = Vec3f(-wo.x, -wo.y, wo.z);
    s.pdf = F;
    s.weight = d.reflect;
    s.eta = 1.f;
    return true;
  }
  float eta = wo.z > 0.f ? d.eta : 1.f / d.eta;  // eta_t / eta_i
  Vec3f n(0.f, 0.f, wo.z > 0.f ? 1.f : -1.f);
  if (!refract(wo, n, eta, s.wi)) return false;
  s.pdf = 1.f - F;
  s.weight = d.transmit;
  if (mode == TransportMode::kRadiance) s.weight /= eta * eta;
  s.eta = eta;
  return true;
}
CHD bool dielectric_sample(const Material& m, Vec3f wo, float u, TransportMode mode, BSDFSample& s) {
  return dielectric_sample(dielectric_params(m), wo, u, mode, s);
}

}  // namespace caustica
