// Photon tracing shared by every photon-mapping integrator (Jensen 1996,
// "Global Illumination using Photon Maps", Sec. 2; Jensen 2001 Ch. 5): a light
// is chosen in proportion to power, a photon emitted from it (light_emit.h)
// and scattered by the same BSDF code as the path tracer, in importance mode
// (no 1/eta^2 on refraction: flux, not radiance, is transported; Veach 1997
// Sec. 5.2). A photon is stored at every non-specular hit. Russian roulette
// keeps powers near constant: continue with q = min(1, max(beta') / max(beta))
// (Jensen 2001 Sec. 5.2, in the throughput form of pbrt-v4's SPPM).
// Each photon path's random stream depends only on (seed, pass, photon index).
//
// Participating media (volumetric photon tracing, Jensen & Christensen 1998, "Efficient Simulation of
// Light Transport in Scenes with Participating Media using Photon Maps"): a photon path starts in the
// medium that encloses its light (locate_medium), samples a free-flight distance on every segment in a
// medium with the path tracer's estimator (medium/medium.h: hero channel, spectral MIS over the path), and at
// a scattering event stores a volume photon (kPhotonVolume) of power beta T sigma_s / p(t), then samples the
// phase function (weight 1) and the same roulette. Null surfaces are crossed without counting a segment; a
// path leaving a medium boundary enters the medium of the side it leaves on. The density of stored power
// per unit volume and solid angle is then sigma_s(x) L(x, w) per emitted path, the in-scattered radiance
// estimate of integrator/sppm.h's sppm_volume_gather.
#pragma once
#include "../base/rng.h"
#include "../light/light_emit.h"
#include "../material/bsdf.h"
#include "../medium/medium_scene.h"
#include "../scene/shading.h"
#include "photon.h"

namespace caustica {

// One photon path's state between bounces: the stage functions below run it one segment at a time (the
// wavefront drivers run each as a kernel over all paths), trace_photon runs them back to back.
// `Rng` supplies the path's random numbers (next_float()): a PCG32 stream, or a primary-sample vector that a
// Markov chain mutates (photon/adaptive.h).
template <typename Rng>
struct PhotonPathStateT {
  Ray ray;
  RGB beta{0.f};
  Rng rng;
  uint32_t depth = 0;  // segments traced so far
  bool specular_seen = false, diffuse_seen = false;
  bool active = false;
  // Participating media (header comment): the medium `ray` travels in (-1: vacuum), the hero channel (-1:
  // none drawn yet), the path's distance densities per channel scaled to average 1, null surfaces crossed
  // since the last vertex.
  int32_t medium = -1;
  int32_t hero = -1;
  RGB r_medium{1.f};
  uint32_t null_crossings = 0;
};
using PhotonPathState = PhotonPathStateT<PCG32>;

// Chooses a light in proportion to power and emits the path's first ray, with the numbers of st.rng (the
// rest of st as default-constructed).
template <typename Rng>
CHD void photon_emit(const SceneView& s, PhotonPathStateT<Rng>& st) {
  if (s.num_lights == 0) return;
  float pmf;
  uint32_t li = s.light_sampler.sample(st.rng.next_float(), pmf);
  EmitSample e;
  Vec2f up(st.rng.next_float(), st.rng.next_float());
  Vec2f ud(st.rng.next_float(), st.rng.next_float());
  if (!sample_emission(s, s.lights[li], up, ud, st.rng.next_float(), e)) return;
  st.beta = e.weight / pmf;
  st.ray = e.ray;
  st.active = true;
}

// photon_emit with a PCG32 stream that depends only on (seed, pass, index).
CHD void photon_start(const SceneView& s, uint64_t seed, uint32_t pass, uint32_t index, PhotonPathState& st) {
  st = PhotonPathState();
  if (s.num_lights == 0) return;
  st.rng = PCG32(hash3(seed, pass, index), mix64(uint64_t(pass) << 32 | index));
  photon_emit(s, st);
}

// The segment st.ray just traced ended at `hit`: stores a photon where the path interacts - a scattering
// event in the medium the segment crosses (a volume photon) or a non-specular surface at `hit` - (returns
// true and fills `ph`), then samples the phase function or BSDF and Russian roulette for the next segment
// (st.active false when the path ends). A null surface at `hit` is crossed (st.active stays true, no
// segment counted). max_depth counts segments from the light (the first hit is depth 1).
template <typename Rng>
CHD bool photon_bounce(const SceneView& s, uint32_t max_depth, PhotonPathStateT<Rng>& st, const Hit& hit, Photon& ph) {
  st.depth += 1;
  if (st.medium >= 0) {
    const Medium& md = s.media[st.medium];
    const float dlen = length(st.ray.d);
    const Vec3f d = st.ray.d / dlen;
    const float u_hero = st.rng.next_float(), u_dist = st.rng.next_float();
    if (st.hero < 0) st.hero = medium_hero_channel(u_hero);
    // A grid medium's delta tracking draws from a stream of its own, seeded by two more of the path's numbers.
    uint64_t track_seed = 0;
    if (md.grid >= 0) {
      const uint32_t a = float_bits(st.rng.next_float());
      track_seed = hash3(uint64_t(a) << 32 | float_bits(st.rng.next_float()), st.depth, 0x9d1c3a5bULL);
    }
    const MediumSample ms =
        medium_sample(s, md, st.ray.o, d, hit.valid() ? hit.t * dlen : kInf, st.hero, u_dist, track_seed);
    const RGB before = st.beta;
    if (!medium_update_throughput(ms, st.beta, st.r_medium) || is_black(st.beta)) {
      st.active = false;
      return false;
    }
    if (ms.scattered) {
      const Vec3f p = st.ray.o + d * ms.t;
      ph.p = p;
      ph.wi = -d;
      ph.power = st.beta;
      ph.flags = kPhotonVolume | (st.depth == 1 ? kPhotonDirect : 0u) | photon_segment_bits(st.depth);
      st.active = false;
      if (st.depth >= max_depth) return true;
      const float u_rr = st.rng.next_float();
      const Vec2f u(st.rng.next_float(), st.rng.next_float());
      float pdf;
      const Vec3f wi = hg_sample(-d, md.g, u, &pdf);  // weight p / pdf = 1
      const float q = minf(1.f, max_component(st.beta) / max_component(before));
      if (!(u_rr < q)) return true;
      st.beta = st.beta / q;
      st.diffuse_seen = true;
      st.ray = Ray{p, wi, kInf};
      st.null_crossings = 0;
      st.active = true;
      return true;
    }
  }
  if (!hit.valid()) {
    st.active = false;
    return false;
  }
  SurfaceHit sh = make_surface_hit(s, st.ray, hit);
  if (is_null_surface(s, sh)) {
    st.depth -= 1;
    st.active = cross_null_surface(s, sh, st.ray, st.medium, st.null_crossings);
    return false;
  }
  st.null_crossings = 0;
  st.beta *= segment_transmittance(s, st.ray.d, hit.t, sh);
  const Material m = surface_material(s, sh);
  Vec3f wo_world = -st.ray.d;
  bool stored = false;
  if (!material_is_delta(m)) {
    ph.p = sh.p;
    ph.wi = wo_world;
    ph.power = st.beta;
    ph.flags = (st.depth == 1 ? kPhotonDirect : 0u) | ((st.specular_seen && !st.diffuse_seen) ? kPhotonCaustic : 0u) |
               photon_segment_bits(st.depth);
    stored = true;
  }
  st.active = false;
  if (st.depth >= max_depth) return stored;
  Frame frame = shading_frame(s, sh, m);
  BSDFSample bs;
  float uc = st.rng.next_float();
  Vec2f u(st.rng.next_float(), st.rng.next_float());
  if (!bsdf_sample(m, frame.to_local(wo_world), uc, u, bs, TransportMode::kImportance)) return stored;
  Vec3f wi_world = frame.to_world(bs.wi);
  if (dot(wi_world, sh.ng) * bs.wi.z * dot(sh.ns, sh.ng) < 0.f) return stored;
  RGB next = st.beta * bs.weight;
  float q = minf(1.f, max_component(next) / max_component(st.beta));
  if (!(st.rng.next_float() < q)) return stored;
  st.beta = next / q;
  if (bs.delta) st.specular_seen = true;
  else st.diffuse_seen = true;
  st.medium = medium_after_crossing(prim_medium_interface(s, sh.prim), wi_world, sh.ng, st.medium);
  st.ray.o = offset_ray_origin(sh.p, sh.ng, wi_world);
  st.ray.d = wi_world;
  st.ray.tmax = kInf;
  st.active = true;
  return stored;
}

// Traces one photon path. `intersect(ray, hit)` is the accelerator's closest
// hit; `store(const Photon&)` receives each stored photon. max_depth counts
// segments from the light (the first hit is depth 1). `outside`: the medium a
// path starts in when its first ray meets no medium boundary (locate_medium; the
// camera's when the camera is outside every boundary, photon_media_setup).
template <typename Rng, typename Intersect, typename Store>
CHD void trace_photon_path(const SceneView& s, PhotonPathStateT<Rng>& st, uint32_t max_depth, Intersect&& intersect,
                           Store&& store, int32_t outside = -1) {
  if (st.active && st.depth == 0) st.medium = locate_medium(s, intersect, st.ray, outside);
  while (st.active && st.depth < max_depth) {
    Hit hit;
    intersect(st.ray, hit);
    Photon ph;
    if (photon_bounce(s, max_depth, st, hit, ph)) store(ph);
  }
}
template <typename Intersect, typename Store>
CHD void trace_photon(const SceneView& s, uint64_t seed, uint32_t pass, uint32_t index, uint32_t max_depth,
                      Intersect&& intersect, Store&& store, int32_t outside = -1) {
  PhotonPathState st;
  photon_start(s, seed, pass, index, st);
  trace_photon_path(s, st, max_depth, intersect, store, outside);
}

}  // namespace caustica
