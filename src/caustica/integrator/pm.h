// Stage functions of Jensen's two-pass photon mapping (`pm`) shared by the CPU driver (photon_render.cpp, on
// nanoflann's kd-tree) and the wavefront driver (wavefront_photon.h, on the portable kd-tree of
// photon/knn_tree.h) on every backend:
//   pm_estimate   the radiance estimate from the k nearest photons of a map (Jensen 2001 Eq. 7.6) with the
//                 cone filter (Eq. 7.7, k_cone = 1: weights 1 - d / r, normalisation 1 - 2 / 3)
//   pm_radiance   one camera sample of a pixel (Jensen 1996, Sec. 4; Jensen 2001 Ch. 9): emission and specular
//                 chains, direct light by NEE (sppm.h's trace_camera), caustics from the caustic map at the
//                 visible point, indirect diffuse light by final gathering - one BSDF-sampled ray whose first
//                 non-specular hit is estimated from the global map.
// A map is anything with `knn(p, k, max_radius, index, dist2)` (nearest first, returning the count) and
// `photon(index)`.
#pragma once
#include "../base/sampler.h"
#include "../material/bsdf.h"
#include "../photon/photon.h"
#include "../scene/shading.h"
#include "sppm.h"

namespace caustica {

// The most photons per estimate (--k) on the wavefront drivers, whose kernels keep the k nearest in fixed
// arrays (2 KiB per thread at 256); the CPU driver takes any k.
constexpr uint32_t kWavefrontMaxK = 256;

// Radiance towards wo at p from the k nearest photons of `map` (paths: photon paths emitted for it); idx and
// d2 hold k entries of scratch.
template <class Map>
CHD RGB pm_estimate(const Map& map, uint64_t paths, uint32_t k, const Material& m, const Frame& frame, Vec3f wo,
                    Vec3f p, uint32_t* idx, float* d2) {
  const uint32_t n = uint32_t(map.knn(p, k, kInf, idx, d2));
  if (n == 0) return RGB(0.f);
  const float r2 = d2[n - 1];
  if (!(r2 > 0.f)) return RGB(0.f);
  const float r = std::sqrt(r2);
  RGB sum(0.f);
  for (uint32_t j = 0; j < n; ++j) {
    const Photon& ph = map.photon(idx[j]);
    const float w = 1.f - std::sqrt(d2[j]) / r;
    sum += bsdf_eval(m, wo, frame.to_local(ph.wi)) * ph.power * w;
  }
  return sum / ((1.f - 2.f / 3.f) * kPi * r2 * float(paths));
}

// One camera sample's radiance along `ray` (the pixel's camera ray; smp its sampler after path_start).
template <class Tracer, class Map>
CHD RGB pm_radiance(const SceneView& v, const Tracer& accel, const Map& caustic, const Map& global, uint64_t paths,
                    uint32_t k, Ray ray, Sampler& smp, uint32_t max_depth, bool light_bvh, uint32_t* idx, float* d2) {
  RGB L(0.f);
  const VisiblePoint vp = trace_camera(v, accel, ray, RGB(1.f), smp, max_depth, L, light_bvh);
  if (!vp.valid) return L;
  const Material& m = vp.material;
  const Frame frame = tangent_frame(vp.ns, vp.tangent);
  const Vec3f wo = frame.to_local(vp.wo);
  L += vp.beta * pm_estimate(caustic, paths, k, m, frame, wo, vp.p, idx, d2);
  // Final gathering: one BSDF-sampled ray; radiance at its non-specular hit (through specular bounces) from
  // the global map. Emission seen by it is direct light, already counted by NEE.
  BSDFSample bs;
  const float uc = smp.next_1d();
  const Vec2f u = smp.next_2d();
  if (!bsdf_sample(m, wo, uc, u, bs) || bs.delta) return L;
  Vec3f wi = frame.to_world(bs.wi);
  Ray r{offset_ray_origin(vp.p, vp.ng, wi), wi, kInf};
  RGB beta = vp.beta * bs.weight;
  for (int bounce = 0; bounce < 8; ++bounce) {
    Hit hit;
    if (!accel.intersect(r, hit)) break;
    SurfaceHit sh = make_surface_hit(v, r, hit);
    beta *= segment_transmittance(v, r.d, hit.t, sh);
    const Material gm = surface_material(v, sh);
    const Frame gf = shading_frame(v, sh, gm);
    const Vec3f gwo = gf.to_local(-r.d);
    if (!material_is_delta(gm)) {
      L += beta * pm_estimate(global, paths, k, gm, gf, gwo, sh.p, idx, d2);
      break;
    }
    BSDFSample gs;
    const float guc = smp.next_1d();
    const Vec2f gu = smp.next_2d();
    if (!bsdf_sample(gm, gwo, guc, gu, gs)) break;
    const Vec3f gwi = gf.to_world(gs.wi);
    beta *= gs.weight;
    r = Ray{offset_ray_origin(sh.p, sh.ng, gwi), gwi, kInf};
  }
  return L;
}

}  // namespace caustica
