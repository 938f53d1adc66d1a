// Lambertian reflection, f = R / pi, cosine-weighted sampling.
#pragma once
#include "../base/sampling.h"
#include "material.h"

namespace caustica {

CHD RGB diffuse_eval(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return RGB(0.f);
  return m.diffuse * kInvPi;
}
CHD float diffuse_pdf(const Material&, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return 0.f;
  return cosine_hemisphere_pdf(wi);
}
CHD bool diffuse_sample(const Material& m, Vec3f wo, Vec2f u, BSDFSample& s) {
  if (wo.z <= 0.f) return false;
  s.wi = square_to_cosine_hemisphere(u);
  s.pdf = cosine_hemisphere_pdf(s.wi);
  if (s.pdf <= 0.f) return false;
  s.weight = m.diffuse;
  s.delta = false;
  return true;
}

}  // namespace caustica
