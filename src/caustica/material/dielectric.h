// Smooth dielectric: specular reflection with probability F and refraction
// with probability 1 - F (exact unpolarised Fresnel, fresnel.h), total
// internal reflection, and the 1/eta^2 scaling of refracted radiance
// (Veach 1997, Eq. 5.14). m.eta = eta_inside / eta_outside; wo.z < 0 is inside.
#pragma once
#include "fresnel.h"
#include "material.h"

namespace caustica {

CHD bool dielectric_sample(const Material& m, Vec3f wo, float u, TransportMode mode, BSDFSample& s) {
  float F = fresnel_dielectric(wo.z, m.eta);
  s.delta = true;
  if (u < F) {
    s.wi = Vec3f(-wo.x, -wo.y, wo.z);
    s.pdf = F;
    s.weight = m.specular;
    s.eta = 1.f;
    return true;
  }
  float eta = wo.z > 0.f ? m.eta : 1.f / m.eta;  // eta_t / eta_i
  Vec3f n(0.f, 0.f, wo.z > 0.f ? 1.f : -1.f);
  if (!refract(wo, n, eta, s.wi)) return false;
  s.pdf = 1.f - F;
  s.weight = m.transmission;
  if (mode == TransportMode::kRadiance) s.weight /= eta * eta;
  s.eta = eta;
  return true;
}

}  // namespace caustica
