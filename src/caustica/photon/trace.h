// Photon tracing shared by every photon-mapping integrator (Jensen 1996,
// "Global Illumination using Photon Maps", Sec. 2; Jensen 2001 Ch. 5): a light
// is chosen in proportion to power, a photon emitted from it (light_emit.h)
// and scattered by the same BSDF code as the path tracer, in importance mode
// (no 1/eta^2 on refraction: flux, not radiance, is transported; Veach 1997
// Sec. 5.2). A photon is stored at every non-specular hit. Russian roulette
// keeps powers near constant: continue with q = min(1, max(beta') / max(beta))
// (Jensen 2001 Sec. 5.2, in the throughput form of pbrt-v4's SPPM).
// Each photon path's random stream depends only on (seed, pass, photon index).
#pragma once
#include "../base/rng.h"
#include "../light/light_emit.h"
#include "../material/bsdf.h"
#include "../scene/shading.h"
#include "photon.h"

namespace caustica {

// Traces one photon path. `intersect(ray, hit)` is the accelerator's closest
// hit; `store(const Photon&)` receives each stored photon. max_depth counts
// segments from the light (the first hit is depth 1).
template <typename Intersect, typename Store>
CHD void trace_photon(const SceneView& s, uint64_t seed, uint32_t pass, uint32_t index, uint32_t max_depth,
                      Intersect&& intersect, Store&& store) {
  if (s.num_lights == 0) return;
  PCG32 rng(hash3(seed, pass, index), mix64(uint64_t(pass) << 32 | index));
  float pmf;
  uint32_t li = s.light_sampler.sample(rng.next_float(), pmf);
  EmitSample e;
  Vec2f up(rng.next_float(), rng.next_float());
  Vec2f ud(rng.next_float(), rng.next_float());
  if (!sample_emission(s, s.lights[li], up, ud, rng.next_float(), e)) return;
  RGB beta = e.weight / pmf;
  Ray ray = e.ray;
  bool specular_seen = false, diffuse_seen = false;
  for (uint32_t depth = 1; depth <= max_depth; ++depth) {
    Hit hit;
    if (!intersect(ray, hit)) return;
    SurfaceHit sh = make_surface_hit(s, ray, hit);
    beta *= segment_transmittance(s, ray.d, hit.t, sh);
    const Material m = surface_material(s, sh);
    Vec3f wo_world = -ray.d;
    if (!material_is_delta(m)) {
      Photon ph;
      ph.p = sh.p;
      ph.wi = wo_world;
      ph.power = beta;
      ph.flags = (depth == 1 ? kPhotonDirect : 0u) | ((specular_seen && !diffuse_seen) ? kPhotonCaustic : 0u);
      store(ph);
    }
    if (depth == max_depth) return;
    Frame frame(sh.ns);
    BSDFSample bs;
    float uc = rng.next_float();
    Vec2f u(rng.next_float(), rng.next_float());
    if (!bsdf_sample(m, frame.to_local(wo_world), uc, u, bs, TransportMode::kImportance)) return;
    Vec3f wi_world = frame.to_world(bs.wi);
    if (dot(wi_world, sh.ng) * bs.wi.z * dot(sh.ns, sh.ng) < 0.f) return;
    RGB next = beta * bs.weight;
    float q = minf(1.f, max_component(next) / max_component(beta));
    if (!(rng.next_float() < q)) return;
    beta = next / q;
    if (bs.delta) specular_seen = true;
    else diffuse_seen = true;
    ray.o = offset_ray_origin(sh.p, sh.ng, wi_world);
    ray.d = wi_world;
    ray.tmax = kInf;
  }
}

}  // namespace caustica
