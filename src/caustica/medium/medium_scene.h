// Media in a scene, for every integrator that renders them (the path tracer, integrator/path.h; volumetric
// photon mapping in pppm, integrator/sppm.h and photon/trace.h): which medium a ray is in after a surface,
// null surfaces, the transmittance of a shadow ray, and where a ray that starts at a light is (locate_medium).
#pragma once
#include "../scene/shading.h"
#include "medium.h"

namespace caustica {

// The most null surfaces one ray crosses between two vertices, or one shadow ray on its way.
constexpr uint32_t kMaxNullCrossings = 64;

// Whether any medium of the scene is a grid (its transmittance an estimate, not exact). Host only: reads the
// host view's media.
inline bool scene_has_grid_media(const SceneView& s) {
  for (uint32_t i = 0; i < s.num_media; ++i)
    if (s.media[i].grid >= 0) return true;
  return false;
}

// The medium interface of primitive `prim` (none when the scene has none).
CHD MediumInterface prim_medium_interface(const SceneView& s, uint32_t prim) {
  return s.prim_medium ? s.prim_medium[prim] : MediumInterface{};
}

// Whether the surface of `sh` is a null surface (MaterialType::kNull): a medium boundary rays cross unchanged.
CHD bool is_null_surface(const SceneView& s, const SurfaceHit& sh) {
  return s.has_null && s.materials[sh.material].type == MaterialType::kNull;
}

// Crosses the null surface at sh that `ray` reached: the ray goes on from just past it, in the medium of the
// side it enters. False (and nothing changed) when the ray has already crossed kMaxNullCrossings since its
// last vertex, the count in `crossings` (a guard against loops).
CHD bool cross_null_surface(const SceneView& s, const SurfaceHit& sh, Ray& ray, int32_t& medium, uint32_t& crossings) {
  if (++crossings > kMaxNullCrossings) return false;
  medium = medium_after_crossing(prim_medium_interface(s, sh.prim), ray.d, sh.ng, medium);
  ray.o = offset_ray_origin(sh.p, sh.ng, ray.d);
  ray.tmax = kInf;
  return true;
}

// Free-flight sampling in medium md along o + t d (unit d) up to the surface at t_surface (infinity: none),
// distances in channel `hero`: a homogeneous medium by sample_medium_distance from u_dist, a grid medium by
// delta tracking (medium/medium_grid.h) with a PCG32 stream seeded by (track_seed, u_dist).
// (The grid media's walks are kept out of line: scenes without them keep the homogeneous path as compact as
// before, measured 2% faster on smallvcm-fog than with the walk inlined.)
CAUSTICA_HOST_DEVICE CAUSTICA_NOINLINE inline MediumSample medium_sample_grid(const SceneView& s, const Medium& md,
                                                                             Vec3f o, Vec3f d, float t_surface,
                                                                             int hero, float u_dist,
                                                                             uint64_t track_seed) {
  PCG32 rng(track_seed, mix64(float_bits(u_dist)));
  return grid_sample_distance(md, s.medium_grids, s.grid_values, o, d, t_surface, hero, rng);
}
CHD MediumSample medium_sample(const SceneView& s, const Medium& md, Vec3f o, Vec3f d, float t_surface, int hero,
                               float u_dist, uint64_t track_seed) {
  if (md.grid < 0) return sample_medium_distance(md, t_surface, hero, u_dist);
  return medium_sample_grid(s, md, o, d, t_surface, hero, u_dist, track_seed);
}

// The transmittance of medium md along o + t d (unit d), 0 <= t < len: exact for a homogeneous medium, by
// ratio tracking for a grid medium, its random stream a hash of the segment and `salt` (so the same query
// always gets the same answer, on any thread or device; ppm's fixed measurement points pass the pass number
// to draw a new estimate for the same segment every pass).
CAUSTICA_HOST_DEVICE CAUSTICA_NOINLINE inline RGB medium_segment_transmittance_grid(const SceneView& s,
                                                                                   const Medium& md, Vec3f o,
                                                                                   Vec3f d, float len,
                                                                                   uint64_t salt) {
  uint64_t h = hash3(uint64_t(float_bits(o.x)) << 32 | float_bits(o.y),
                     uint64_t(float_bits(o.z)) << 32 | float_bits(d.x),
                     uint64_t(float_bits(d.y)) << 32 | float_bits(d.z));
  if (salt != 0) h = mix64(h ^ mix64(salt));
  PCG32 rng(h, mix64(h ^ float_bits(len)));
  return grid_transmittance(md, s.medium_grids, s.grid_values, o, d, len, rng);
}
CHD RGB medium_segment_transmittance(const SceneView& s, const Medium& md, Vec3f o, Vec3f d, float len,
                                     uint64_t salt = 0) {
  if (md.grid < 0) return medium_transmittance(medium_sigma_t(md), len);
  return medium_segment_transmittance_grid(s, md, o, d, len, salt);
}

// The fraction of a shadow ray's contribution that arrives: 0 or 1 from one occlusion query in scenes
// without media; otherwise the product of the media's transmittances along it, through null surfaces
// (any other surface occludes; grid media by ratio tracking). `tracer` is any type with intersect(Ray, Hit&) and
// occluded(Ray).
template <typename Tracer>
CHD RGB shadow_transmittance(const SceneView& s, const Tracer& tracer, Ray r, int32_t medium) {
  if (!scene_has_media(s)) return tracer.occluded(r) ? RGB(0.f) : RGB(1.f);
  const float dlen = length(r.d);
  RGB Tr(1.f);
  for (uint32_t k = 0; k <= kMaxNullCrossings; ++k) {
    Hit h;
    tracer.intersect(r, h);
    const float t = h.valid() ? h.t : r.tmax;
    if (medium >= 0) {
      Tr *= medium_segment_transmittance(s, s.media[medium], r.o, r.d / dlen, t * dlen);
      if (is_black(Tr)) return Tr;
    }
    if (!h.valid()) return Tr;
    if (s.materials[s.prim_material[h.prim]].type != MaterialType::kNull) return RGB(0.f);
    SurfaceHit sh = make_surface_hit(s, r, h);
    medium = medium_after_crossing(prim_medium_interface(s, h.prim), r.d, sh.ng, medium);
    Vec3f o = offset_ray_origin(sh.p, sh.ng, r.d);
    // The rest of the segment, from just past the surface (d keeps its length, so t stays comparable).
    r.tmax = r.tmax - t - dot(o - sh.p, r.d) / (dlen * dlen);
    r.o = o;
    if (!(r.tmax > 0.f)) return Tr;
  }
  return RGB(0.f);
}

// The medium that ray r starts in, found by following it (through every surface) to the first medium
// boundary it meets: that boundary's exterior when r arrives on its front, its interior when from behind;
// vacuum (-1) when r meets no boundary. Photon paths start with it (the camera's medium is the scene's
// camera_medium instead), so a light is in the medium whose boundary encloses it, as in pbrt-v4 and
// Mitsuba 3 where media are closed shapes. `intersect(ray, hit)` is the accelerator's closest hit. `outside`:
// what a ray that meets no boundary gets (vacuum by default; the bidirectional integrators pass the medium of
// the region outside every boundary, which is the camera's when the camera is in that region).
template <typename Intersect>
CHD int32_t locate_medium(const SceneView& s, Intersect&& intersect, Ray r, int32_t outside = -1) {
  if (!s.prim_medium) return outside;
  for (uint32_t k = 0; k <= kMaxNullCrossings; ++k) {
    Hit h;
    intersect(r, h);
    if (!h.valid()) return outside;
    const MediumInterface mi = prim_medium_interface(s, h.prim);
    const SurfaceHit sh = make_surface_hit(s, r, h);
    if (mi.transition) return dot(r.d, sh.ng) < 0.f ? mi.exterior : mi.interior;
    r.o = offset_ray_origin(sh.p, sh.ng, r.d);
    r.tmax = kInf;
  }
  return -1;
}

}  // namespace caustica
