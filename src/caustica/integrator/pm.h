// Stage functions of Jensen's two-pass photon mapping (`pm`) shared by the CPU driver (photon_render.cpp, on
// nanoflann's kd-tree) and the wavefront driver (wavefront_photon.h, on the portable kd-tree of
// photon/knn_tree.h) on every backend:
//   pm_estimate   the radiance estimate from the k nearest photons of a map (Jensen 2001 Eq. 7.6) with the
//                 cone filter (Eq. 7.7, k_cone = 1: weights 1 - d / r, normalisation 1 - 2 / 3)
//   pm_radiance   one camera sample of a pixel (Jensen 1996, Sec. 4; Jensen 2001 Ch. 9): emission and specular
//                 chains, direct light by NEE (sppm.h's trace_camera), caustics from the caustic map at the
//                 visible point, indirect diffuse light by final gathering - one BSDF-sampled ray whose first
//                 non-specular hit is estimated from the global map.
//   pm_volume_estimate  the in-scattered radiance at a point in a medium from the k nearest volume photons
//                 (Jensen & Christensen 1998, "Efficient Simulation of Light Transport in Scenes with
//                 Participating Media using Photon Maps", Sec. 4.2, their volume radiance estimate)
// A map is anything with `knn(p, k, max_radius, index, dist2)` (nearest first, returning the count) and
// `photon(index)`.
//
// Participating media (Jensen & Christensen 1998): photon paths store volume photons at their scattering
// events (photon/trace.h, power beta T sigma_s / p(t)), kept in two more maps: every volume photon (`volume`)
// and those after at least one bounce (`volume_indirect`, the paper's multiple scattering). A camera ray
// samples free-flight distances (trace_camera, as sppm's camera rays do); at a scattering event x it adds
// single scattering by NEE with the phase function and multiple scattering from `volume_indirect`:
//   L_s(x, wo) ~ sum_j p(wo, wi_j) power_j / (N 4/3 pi r^3),
// r the distance to the k-th nearest volume photon (the paper's estimate, with sigma_s folded into the
// photons' power; uniform kernel). At a surface point the final-gather ray also samples free-flight
// distances through the media it crosses, starting in the medium of the side it leaves on; where it scatters
// the in-scattered radiance there comes from `volume` (all orders, as the global map holds direct photons
// too), and the caustic map holds only L S+ D paths (a volume event counts as diffuse). Each of the two rays
// draws its own hero channel (medium/medium.h): the gather's one-sample MIS over channels is unbiased on its
// own, so their product is too.
#pragma once
#include <vector>

#include "../base/sampler.h"
#include "../material/bsdf.h"
#include "../photon/photon.h"
#include "../scene/shading.h"
#include "sppm.h"

namespace caustica {

// The most photons per estimate (--k) on the wavefront drivers, whose kernels keep the k nearest in fixed
// arrays (2 KiB per thread at 256); the CPU driver takes any k.
constexpr uint32_t kWavefrontMaxK = 256;

// In-scattered radiance towards wo (world space) at p in a medium of asymmetry g from the k nearest photons
// of the volume map `map` (header comment), those of more than `budget` segments left out (below); idx and d2
// hold k entries of scratch.
template <class Map>
CHD RGB pm_volume_estimate(const Map& map, uint64_t paths, uint32_t k, uint32_t budget, float g, Vec3f wo, Vec3f p,
                           uint32_t* idx, float* d2) {
  const uint32_t n = uint32_t(map.knn(p, k, kInf, idx, d2));
  if (n == 0) return RGB(0.f);
  const float r2 = d2[n - 1];
  if (!(r2 > 0.f)) return RGB(0.f);
  RGB sum(0.f);
  for (uint32_t j = 0; j < n; ++j) {
    const Photon& ph = map.photon(idx[j]);
    if (photon_segments(ph) <= budget) sum += ph.power * hg_phase(dot(wo, ph.wi), g);
  }
  return sum / (4.f / 3.f * kPi * r2 * std::sqrt(r2) * float(paths));
}

// Radiance towards wo at p from the k nearest photons of `map` (paths: photon paths emitted for it); idx and
// d2 hold k entries of scratch. The photons of more than `budget` segments (photon.h's photon_budget: the
// paths they would close are longer than max_depth) add nothing but still set the radius, as in Mitsuba's
// photon mapper: the estimate is the density of the photons that fit within the k nearest of all, a kernel
// estimate whose radius does not depend on which of them fit.
template <class Map>
CHD RGB pm_estimate(const Map& map, uint64_t paths, uint32_t k, uint32_t budget, const Material& m,
                    const Frame& frame, Vec3f wo, Vec3f p, uint32_t* idx, float* d2) {
  const uint32_t n = uint32_t(map.knn(p, k, kInf, idx, d2));
  if (n == 0) return RGB(0.f);
  const float r2 = d2[n - 1];
  if (!(r2 > 0.f)) return RGB(0.f);
  const float r = std::sqrt(r2);
  RGB sum(0.f);
  for (uint32_t j = 0; j < n; ++j) {
    const Photon& ph = map.photon(idx[j]);
    if (photon_segments(ph) > budget) continue;
    const float w = 1.f - std::sqrt(d2[j]) / r;
    sum += bsdf_eval(m, wo, frame.to_local(ph.wi)) * ph.power * w;
  }
  return sum / ((1.f - 2.f / 3.f) * kPi * r2 * float(paths));
}

// The photon maps of pm_radiance (header comment): `volume` and `volume_indirect` are empty without media.
template <class Map>
struct PmMaps {
  const Map& caustic;
  const Map& global;
  const Map& volume;
  const Map& volume_indirect;
};

// pm's photons split into its four maps (header comment; each keeps the photons' trace order).
struct PmPhotonSplit {
  std::vector<Photon> global, caustic, volume, volume_indirect;
};
inline PmPhotonSplit pm_split_photons(const std::vector<Photon>& all) {
  PmPhotonSplit out;
  for (const Photon& ph : all) {
    if (ph.flags & kPhotonVolume) {
      out.volume.push_back(ph);
      if (!(ph.flags & kPhotonDirect)) out.volume_indirect.push_back(ph);
      continue;
    }
    out.global.push_back(ph);
    if (ph.flags & kPhotonCaustic) out.caustic.push_back(ph);
  }
  return out;
}

// The most segments a final-gather ray follows through specular surfaces to the point it estimates from.
constexpr uint32_t kPmGatherDepth = 8;

// One camera sample's radiance along `ray` (the pixel's camera ray; smp its sampler after path_start).
template <class Tracer, class Map>
CHD RGB pm_radiance(const SceneView& v, const Tracer& accel, const PmMaps<Map>& maps, uint64_t paths, uint32_t k,
                    Ray ray, Sampler& smp, uint32_t max_depth, bool light_bvh, uint32_t* idx, float* d2,
                    bool hide_emitters = false) {
  RGB L(0.f);
  const VisiblePoint vp =
      trace_camera(v, accel, ray, RGB(1.f), smp, max_depth, L, light_bvh, true, kCameraMedium, hide_emitters);
  if (!vp.valid) return L;
  const uint32_t budget = photon_budget(max_depth, vp.depth);
  if (vp.volume) {  // single scattering came by NEE; the rest from the volume photons after a bounce
    L += vp.beta *
         pm_volume_estimate(maps.volume_indirect, paths, k, budget, v.media[vp.medium].g, vp.wo, vp.p, idx, d2);
    return L;
  }
  const Material& m = vp.material;
  const Frame frame = tangent_frame(vp.ns, vp.tangent);
  const Vec3f wo = frame.to_local(vp.wo);
  L += vp.beta * pm_estimate(maps.caustic, paths, k, budget, m, frame, wo, vp.p, idx, d2);
  // Final gathering: one BSDF-sampled ray; radiance at its first non-specular hit or scattering event
  // (through specular bounces, kPmGatherDepth segments at most) from the global or volume map. Emission and
  // light sources seen by it are direct light, already counted by NEE (trace_camera with direct false). The
  // gather point is vp.depth + gp.depth segments from the camera, and its photons must close the path within
  // max_depth: with fewer than two segments left (the gather's and a photon's) it adds nothing.
  if (budget < 2) return L;
  BSDFSample bs;
  const float uc = smp.next_1d();
  const Vec2f u = smp.next_2d();
  if (!bsdf_sample(m, wo, uc, u, bs) || bs.delta) return L;
  const Vec3f wi = frame.to_world(bs.wi);
  const int32_t medium =
      scene_has_media(v) ? medium_after_crossing(prim_medium_interface(v, uint32_t(vp.prim)), wi, vp.ng, vp.medium) : -1;
  RGB unused(0.f);
  const VisiblePoint gp =
      trace_camera(v, accel, Ray{offset_ray_origin(vp.p, vp.ng, wi), wi, kInf}, vp.beta * bs.weight, smp,
                   budget < kPmGatherDepth + 1 ? budget : kPmGatherDepth + 1, unused, false, false, medium);
  if (!gp.valid) return L;
  const uint32_t gather_budget = photon_budget(max_depth, vp.depth + gp.depth);
  if (gp.volume)
    return L + gp.beta * pm_volume_estimate(maps.volume, paths, k, gather_budget, v.media[gp.medium].g, gp.wo,
                                            gp.p, idx, d2);
  const Frame gf = tangent_frame(gp.ns, gp.tangent);
  return L + gp.beta * pm_estimate(maps.global, paths, k, gather_budget, gp.material, gf, gf.to_local(gp.wo),
                                   gp.p, idx, d2);
}

}  // namespace caustica
