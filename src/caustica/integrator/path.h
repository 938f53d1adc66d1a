// Path tracing with next-event estimation and multiple importance sampling
// (Kajiya 1986, "The Rendering Equation"; Veach & Guibas 1995, "Optimally
// Combining Sampling Techniques for Monte Carlo Rendering"; Veach 1997 Ch. 9:
// the power heuristic with beta = 2, Eq. 9.13). One BSDF sample and one light
// sample per vertex; the light is chosen in proportion to its power.
// Russian roulette after rr_depth segments with continuation probability
// q = min(max(beta) * eta_scale^2, 0.95) (the rule of Mitsuba 3 and pbrt-v4).
//
// The integrator is written as stage functions over a small per-path state, so
// that the CPU runs one path's stages back to back and the GPU runs each stage
// as a kernel over a queue of paths (wavefront):
//   path_start  -> camera ray
//   [intersect]   closest hit of state.ray
//   path_shade  -> emission with MIS, NEE (a shadow ray), BSDF sampling, RR
//   [occluded]    any hit of the shadow ray
//   path_shadow -> adds the NEE contribution if unoccluded
// Depth counts segments as Mitsuba does: the camera segment is depth 1, so
// max_depth = 1 shows only emitters and 2 adds direct lighting.
//
// Participating media (volumetric path tracing; the radiative transfer equation in pbrt-v4 Eq. 14.3, the
// estimator of pbrt-v3 Sec. 15.2 with pbrt-v4's spectral MIS over the path, medium/medium.h; heterogeneous
// media by delta and ratio tracking, medium/medium_grid.h): a path knows
// the medium its ray travels in. Before a surface, path_shade samples a free-flight distance; a scattering
// event in the medium is a vertex like a surface's, with the phase function in the place of the BSDF (NEE
// with MIS, phase sampling, Russian roulette). Leaving a surface with a medium interface puts the ray in the
// medium of the side it leaves on; null surfaces (MaterialType::kNull) are crossed without counting a
// segment. Shadow rays carry the transmittance of the media they pass, through null surfaces
// (path_shadow_transmittance).
#pragma once
#include "../base/sampler.h"
#include "../light/light_sample.h"
#include "../material/bsdf.h"
#include "../medium/medium_scene.h"
#include "../scene/shading.h"

namespace caustica {

// Arbitrary output variables (path's --aov; Mitsuba's `aov` integrator has the same quantities): instead of
// radiance, each sample carries one value of the first surface its camera ray reaches (through null boundaries,
// ignoring media), 0 where it reaches none; the film averages them over the pixel like radiance.
enum class Aov : uint32_t {
  kNone = 0,
  kDepth,      // distance from the camera ray's origin (Mitsuba's "depth": the hit's t along a unit direction)
  kPosition,   // the world-space point
  kNormal,     // the shading normal (interpolated vertex normals; before normal and bump maps), world space
  kGeoNormal,  // the geometric normal
  kUv,         // the texture coordinates (u, v, 0), caustica's v (up the image)
  kAlbedo,     // the material's main colour after textures and vertex colours (surface_material's tint)
};

struct PathParams {
  uint32_t max_depth = 0xffffffffu;  // segments; 0xffffffff: unlimited
  uint32_t rr_depth = 5;
  uint64_t seed = 0;
  SamplerType sampler = SamplerType::kSobol;
  bool jitter = true;  // false: every sample through the pixel centre, weight 1 (camera rays repeat per pass)
  bool light_bvh = false;  // choose lights by the light BVH (light/light_bvh.h) instead of by power alone
  // Emitters seen directly from the camera (area lights and the environment at the end of the camera segment,
  // null boundaries crossed on the way) add nothing; they still block what lies behind them (Mitsuba's
  // hide_emitters). Emissive media, and emitters seen through a reflection or refraction, stay visible.
  bool hide_emitters = false;
  Aov aov = Aov::kNone;  // an output variable instead of radiance (path_aov)
  // Whether the emission reached at the end of segment `depth` (1: the camera's) is added.
  CHD bool shows_emission(uint32_t depth) const { return !hide_emitters || depth > 1; }
};

// The probability that next-event estimation from reference point p chooses `light`.
CHD float path_light_pmf(const SceneView& s, const PathParams& pp, Vec3f p, uint32_t light) {
  return pp.light_bvh ? light_bvh_pmf(s.light_bvh, p, light) : s.light_sampler.pmf[light];
}

struct PathState {
  Ray ray;
  RGB beta{1.f};     // throughput
  RGB L{0.f};        // radiance gathered so far
  float weight = 1.f;  // pixel filter weight of this sample
  float prev_pdf = 1.f;  // solid-angle pdf of the BSDF sample that made `ray`
  bool prev_delta = true;  // camera rays and delta BSDF samples skip MIS on emitters
  // The emitters `ray` reaches were already estimated by light sampling alone at the previous vertex (the
  // ReSTIR integrator's direct light, integrator/restir.h): their emission is not added again.
  bool nee_only = false;
  bool active = true;
  uint32_t depth = 0;  // segments traced before `ray`
  float eta_scale = 1.f;
  Vec3f prev_p;      // origin of `ray` (for the light's density at hits)
  int32_t medium = -1;  // the participating medium `ray` travels in (-1: vacuum)
  int32_t hero = -1;    // the colour channel that samples distances in media (-1: none chosen yet)
  RGB r_medium{1.f};    // the path's distance densities per channel over the hero's, scaled to average 1
  uint32_t null_crossings = 0;  // null surfaces crossed since the last vertex (a guard against loops)
  uint32_t pixel = 0;
  Sampler sampler;
};

struct ShadowRay {
  Ray ray;
  RGB contrib{0.f};
  bool active = false;
  int32_t medium = -1;  // the medium the ray starts in (path_shadow_transmittance)
};

// The vertex path_shade made where it samples the next-event estimation (a non-delta surface or a scattering
// event in a medium, within max_depth), for a driver that estimates the direct light there itself (restir.h's
// shading point): the surface as make_surface_hit made it (before surface_material's normal mapping) or the
// event's position (sh.p only), the direction towards the previous vertex, the throughput there (with sigma_s
// at a medium event) and the medium the path arrived in.
struct PathVertex {
  SurfaceHit sh;
  Vec3f wo;
  RGB beta{0.f};
  int32_t medium = -1;
  bool volume = false;
  bool valid = false;
};

// Whether the path tracer's drivers give path_shade a second shadow ray for equiangular sampling.
CHD bool scene_wants_equiangular(const SceneView& s) { return s.num_media > 0 && s.num_point_lights > 0; }

template <typename Tracer>
CHD RGB path_shadow_transmittance(const SceneView& s, const Tracer& tracer, const ShadowRay& sr) {
  return shadow_transmittance(s, tracer, sr.ray, sr.medium);
}

CHD void path_start(const SceneView& s, const PathParams& pp, uint32_t px, uint32_t py, uint32_t sample_index,
                    PathState& st) {
  st = PathState();
  st.pixel = py * uint32_t(s.camera.width) + px;
  st.sampler.start(pp.sampler, pp.seed, s.camera.film_pixel(px, py), sample_index);
  FilterSample fs = filter_sample(s.filter, st.sampler.next_2d());
  if (!pp.jitter) fs = FilterSample{Vec2f(0.f, 0.f), 1.f, 1.f};
  // A pinhole camera takes no lens sample (and spends no dimension on one).
  Vec2f lens = s.camera.aperture_radius > 0.f ? st.sampler.next_2d() : Vec2f(0.5f, 0.5f);
  Vec2f film(float(px) + 0.5f + fs.offset.x, float(py) + 0.5f + fs.offset.y);
  // A moving camera takes a time in the shutter interval (a static one spends no dimension on it).
  st.ray = s.camera.moving ? s.camera.at(st.sampler.next_1d()).generate_ray(film, lens)
                           : s.camera.generate_ray(film, lens);
  st.prev_p = st.ray.o;
  st.weight = fs.weight;
  st.medium = s.camera_medium;
}

// Emission of the area light at sh reached by the ray that ends there (the BSDF sample of the previous
// vertex, or the camera ray): MIS-weighted against light sampling unless that ray came from a delta
// lobe or the camera. Also called per lane by the lane-parallel driver (path_lanes.cpp).
CHD void path_add_emission(const SceneView& s, const PathParams& pp, const SurfaceHit& sh, Vec3f wo_world,
                           Vec3f prev_p, float prev_pdf, bool prev_delta, RGB beta, RGB& L) {
  if (sh.light < 0) return;
  const Light& l = s.lights[sh.light];
  RGB Le = area_radiance(s, l, sh.ng, wo_world, sh.uv);
  if (is_black(Le)) return;
  float w = 1.f;
  if (!prev_delta) {
    float lp = path_light_pmf(s, pp, prev_p, uint32_t(sh.light)) * light_pdf(s, l, prev_p, sh.p, sh.ng);
    w = power_heuristic(prev_pdf, lp);
  }
  L += beta * Le * w;
}

// NEE's light sample from p: a light chosen by choose_light from u.x (its index to *light, its probability to
// pmf), then a point or direction on it from the remapped u. Returns false when no light sample was made.
CHD bool path_light_sample(const SceneView& s, const PathParams& pp, Vec3f p, Vec2f u, LightSample& ls, float& pmf,
                           int32_t* light = nullptr) {
  pmf = 0.f;
  int32_t li = choose_light(s, pp.light_bvh, p, u, pmf);
  if (light) *light = li;
  return li >= 0 && sample_light(s, s.lights[li], p, u, ls);
}
// Russian roulette after a vertex's sampling (the rule in the header comment), with u_rr its uniform number;
// ends the path where the throughput is black or the roulette says so.
CHD void path_roulette(const PathParams& pp, PathState& st, float u_rr) {
  if (is_black(st.beta)) { st.active = false; return; }
  if (st.depth >= pp.rr_depth) {
    float q = minf(max_component(st.beta) * st.eta_scale, 0.95f);
    if (!(u_rr < q)) { st.active = false; return; }
    st.beta /= q;
  }
}

CHD void path_shadow_ray_to(ShadowRay& sr, Vec3f o, const LightSample& ls) {
  if (std::isfinite(ls.dist)) {
    sr.ray = spawn_ray_to(o, ls.p_l, ls.n_l);
  } else {
    sr.ray.o = o;
    sr.ray.d = ls.wi;
    sr.ray.tmax = kInf;
  }
}

// The density with which equiangular sampling (path_equiangular) on the segment o + t d, t < t_max, picks
// light li and then distance t: the light's probability from o times the equiangular density.
CHD float path_equiangular_density(const SceneView& s, const PathParams& pp, Vec3f o, Vec3f d, float t_max,
                                   int32_t li, float t) {
  const Light& l = s.lights[li];
  if (l.type != LightType::kPoint && l.type != LightType::kSpot) return 0.f;
  return path_light_pmf(s, pp, o, uint32_t(li)) * equiangular_pdf(equiangular_segment(o, d, t_max, l.p), t);
}

// Equiangular sampling (Kulla & Fajardo 2012, Sec. 4.1) of the single scattering from a point or spot light
// along the segment o + t d (unit d, t < t_max) that the path just traced through medium `md`: a light chosen
// from o, a distance t by medium/medium.h's equiangular_sample, and the phase function and transmittance to
// the light there, as the shadow ray `eq`. Combined by the power heuristic with the same light's NEE at a
// free-flight scattering event at t (path_scatter_in_medium), whose density is q(t) = the channels' average
// of r sigma_t T(t) (the path's free-flight density, medium/medium.h) times the light's probability from
// x(t). Kulla and Fajardo combine the two strategies the same way (their Sec. 4.1 and 5).
//
// In a grid medium (medium/medium_grid.h) the free-flight density of t has no closed form, so both MIS
// weights use a proxy for it that either strategy can compute without random numbers, avg_c(r_c sigma_t[c](x)
// exp(-sigma_t[c] D(t))) with D the majorant's optical depth per unit sigma_t (grid_majorant_depth): the
// weights still sum to 1 for every (light, t), which is all the combination needs to stay unbiased (Veach
// 1997 Sec. 9.2.2: any weights that sum to 1); the transmittance to x(t) in the equiangular estimate is ratio
// tracking's (unbiased) estimate.
// `sigma_t_x` is the medium's sigma_t at x(t).
CHD float path_grid_freeflight_proxy(const SceneView& s, const Medium& md, const RGB& r_medium, Vec3f o, Vec3f d,
                                     float t, RGB sigma_t_x) {
  const float depth = grid_majorant_depth(s.medium_grids[md.grid], s.grid_values, o, d, t);
  const RGB q = r_medium * sigma_t_x * medium_transmittance(medium_sigma_t(md), depth);
  return (q.x + q.y + q.z) * (1.f / 3.f);
}

CHD void path_equiangular(const SceneView& s, const PathParams& pp, const PathState& st, const Medium& md, Vec3f o,
                          Vec3f d, float t_max, Vec2f u, ShadowRay& eq) {
  float pmf = 0.f;
  const int32_t li = choose_light(s, pp.light_bvh, o, u, pmf);
  if (li < 0) return;
  const Light& l = s.lights[li];
  if (l.type != LightType::kPoint && l.type != LightType::kSpot) return;
  EquiangularSegment e = equiangular_segment(o, d, t_max, l.p);
  if (!e.valid) return;
  const float t = equiangular_sample(e, u.y);
  if (!(t >= 0.f && t < t_max)) return;
  const float pe = equiangular_pdf(e, t);
  const Vec3f x = o + d * t;
  LightSample ls;
  if (!(pe > 0.f) || !sample_light(s, l, x, Vec2f(0.5f, 0.5f), ls)) return;
  RGB T, sigma_s;
  float q_ff;
  if (md.grid < 0) {
    const RGB st_ = medium_sigma_t(md);
    T = medium_transmittance(st_, t);
    sigma_s = md.sigma_s;
    const RGB rp = st.r_medium * st_ * T;
    q_ff = (rp.x + rp.y + rp.z) * (1.f / 3.f);
  } else {
    const GridCoefficients c = grid_coefficients(md, s.medium_grids, s.grid_values, x);
    T = medium_segment_transmittance(s, md, o, d, t);
    sigma_s = c.sigma_s;
    q_ff = path_grid_freeflight_proxy(s, md, st.r_medium, o, d, t, c.sigma_t);
  }
  const float q = q_ff * path_light_pmf(s, pp, x, uint32_t(li));
  const float a = pmf * pe, w = a * a / (a * a + q * q);
  eq.contrib = st.beta * sigma_s * T * ls.Li * (hg_phase(dot(-d, ls.wi), md.g) * w / a);
  eq.ray = spawn_ray_to(x, ls.p_l, ls.n_l);
  eq.medium = st.medium;
  eq.active = !is_black(eq.contrib) && isfinite3(eq.contrib);
}

// A scattering event in medium `md` at distance t along st.ray (st.beta already holds the distance
// sample's factor; q is the free-flight density of t, the channels' average of r sigma_t T(t) before the
// event, and (o, d, t_max) the segment, unit d, for the MIS weight against path_equiangular, which ran on
// this segment when `equiangular`): NEE with the phase function, MIS against phase sampling (and equiangular
// sampling for point and spot lights), the next direction, roulette.
CHD void path_scatter_in_medium(const SceneView& s, const PathParams& pp, PathState& st, const Medium& md, float t,
                                float q, Vec3f o, Vec3f d, float t_max, bool equiangular, ShadowRay& sr) {
  const Vec3f p = st.ray.o + st.ray.d * t;
  const Vec3f wo = -normalize(st.ray.d);
  Vec2f u_light2 = st.sampler.next_2d();
  if (s.num_lights > 0) {
    float pmf;
    LightSample ls;
    int32_t li = -1;
    if (path_light_sample(s, pp, p, u_light2, ls, pmf, &li)) {
      float ph = hg_phase(dot(wo, ls.wi), md.g);
      float w = 1.f;
      if (!ls.delta) {
        w = power_heuristic(pmf * ls.pdf, ph);
      } else if (equiangular) {
        const float a = path_equiangular_density(s, pp, o, d, t_max, li, t * length(st.ray.d));
        const float b = pmf * q;
        w = b * b / (a * a + b * b);
      }
      sr.contrib = st.beta * ls.Li * (ph * w / (pmf * ls.pdf));
      path_shadow_ray_to(sr, p, ls);
      sr.medium = st.medium;
      sr.active = !is_black(sr.contrib) && isfinite3(sr.contrib);
    }
  }
  Vec2f u_lobe_rr = st.sampler.next_2d();
  Vec2f u_phase = st.sampler.next_2d();
  float pdf;
  Vec3f wi = hg_sample(wo, md.g, u_phase, &pdf);
  st.prev_pdf = pdf;  // the phase function's weight p / pdf is 1
  st.prev_delta = false;
  st.ray.o = p;
  st.ray.d = wi;
  st.ray.tmax = kInf;
  st.prev_p = p;
  st.null_crossings = 0;
  path_roulette(pp, st, u_lobe_rr.y);
}

// The output variable `aov` of the surface point sh that the camera ray from `origin` reached (through null
// boundaries: Aov).
CHD RGB path_aov(const SceneView& s, Aov aov, Vec3f origin, SurfaceHit sh) {
  switch (aov) {
    case Aov::kDepth: return RGB(length(sh.p - origin));
    case Aov::kPosition: return RGB(sh.p.x, sh.p.y, sh.p.z);
    case Aov::kNormal: return RGB(sh.ns.x, sh.ns.y, sh.ns.z);
    case Aov::kGeoNormal: return RGB(sh.ng.x, sh.ng.y, sh.ng.z);
    case Aov::kUv: return RGB(sh.uv.x, sh.uv.y, 0.f);
    case Aov::kAlbedo: {
      Material m = surface_material(s, sh);
      return main_colour(m);
    }
    default: return RGB(0.f);
  }
}

// `eq` receives the equiangular shadow ray of a segment in a medium (path_equiangular); drivers pass it
// where the scene has media and point or spot lights (scene_wants_equiangular), else null. `vertex` (null for
// the path tracer itself) receives the vertex where next-event estimation is sampled, if this step makes one
// (PathVertex).
CHD void path_shade(const SceneView& s, const PathParams& pp, PathState& st, const Hit& hit, ShadowRay& sr,
                    ShadowRay* eq = nullptr, PathVertex* vertex = nullptr) {
  sr.active = false;
  if (eq) eq->active = false;
  st.depth += 1;  // the segment just traced
  if (st.medium >= 0 && pp.aov == Aov::kNone) {
    const Medium& md = s.media[st.medium];
    const float dlen = length(st.ray.d);
    const Vec3f o = st.ray.o, d = st.ray.d / dlen;
    const float t_max = hit.valid() ? hit.t * dlen : kInf;
    // Equiangular single scattering from point and spot lights along the segment (its own shadow ray).
    // (In a grid medium the MIS weights use a proxy for the free-flight density: path_equiangular.)
    const bool equiangular = eq && s.num_point_lights > 0 && st.depth < pp.max_depth;
    if (equiangular) {
      Vec2f u_eq = st.sampler.next_2d();
      path_equiangular(s, pp, st, md, o, d, t_max, u_eq, *eq);
    }
    // Free-flight sampling up to the surface (medium/medium.h; delta tracking in a grid medium,
    // medium/medium_grid.h, from a stream of its own seeded by the sampler's state).
    const uint64_t track_seed = md.grid >= 0 ? st.sampler.stream_seed() : 0;
    Vec2f u_m = st.sampler.next_2d();
    // The hero channel is drawn at the path's first medium event (u_m.x) and kept (medium/medium.h).
    if (st.hero < 0) st.hero = medium_hero_channel(u_m.x);
    MediumSample ms = medium_sample(s, md, o, d, t_max, st.hero, u_m.y, track_seed);
    const RGB rp = st.r_medium * ms.p;
    float q = (rp.x + rp.y + rp.z) * (1.f / 3.f);
    // A grid medium's event densities are relative (medium_grid.h): the MIS weight takes the proxy instead.
    if (md.grid >= 0 && equiangular && ms.scattered)
      q = path_grid_freeflight_proxy(
          s, md, st.r_medium, o, d, ms.t,
          medium_sigma_t(md) * grid_value(s.medium_grids[md.grid], s.grid_values, o + d * ms.t));
    // An emissive medium's emission at the event (medium/medium.h), with the throughput before it.
    st.L += medium_event_emission(ms, st.beta, st.r_medium);
    if (!medium_update_throughput(ms, st.beta, st.r_medium) || is_black(st.beta)) { st.active = false; return; }
    if (ms.scattered) {
      if (st.depth >= pp.max_depth) { st.active = false; return; }
      // The emitters the ray reaches from here are this vertex's to estimate again (nee_only: a previous
      // vertex's estimate covered only the segment's end).
      st.nee_only = false;
      if (vertex) {
        vertex->sh.p = st.ray.o + st.ray.d * (ms.t / dlen);
        vertex->wo = -d;
        vertex->beta = st.beta;
        vertex->medium = st.medium;
        vertex->volume = true;
        vertex->valid = true;
      }
      path_scatter_in_medium(s, pp, st, md, ms.t / dlen, q, o, d, t_max, equiangular, sr);
      return;
    }
  }
  if (!hit.valid()) {
    if (s.environment_light >= 0 && !st.nee_only && pp.shows_emission(st.depth) && pp.aov == Aov::kNone) {
      const Light& env = s.lights[s.environment_light];
      float w = 1.f;
      if (!st.prev_delta) {
        float light_pdf_sa = path_light_pmf(s, pp, st.prev_p, uint32_t(s.environment_light)) *
                             environment_pdf(s, env, st.ray.d);
        w = power_heuristic(st.prev_pdf, light_pdf_sa);
      }
      st.L += st.beta * environment_radiance(s, env, st.ray.d) * w;
    }
    st.active = false;
    return;
  }
  SurfaceHit sh = make_surface_hit(s, st.ray, hit);
  Vec3f wo_world = -st.ray.d;
  if (pp.aov != Aov::kNone && !is_null_surface(s, sh)) {
    st.L = path_aov(s, pp.aov, st.prev_p, sh);  // prev_p: the camera ray's origin, kept across null crossings
    st.active = false;
    return;
  }
  st.beta *= segment_transmittance(s, st.ray.d, hit.t, sh);

  if (!st.nee_only && pp.shows_emission(st.depth))
    path_add_emission(s, pp, sh, wo_world, st.prev_p, st.prev_pdf, st.prev_delta, st.beta, st.L);
  if (is_null_surface(s, sh)) {
    // A null surface: the ray goes on unchanged, into the medium behind it, and no segment is counted
    // (prev_p, prev_pdf, prev_delta and nee_only stay those of the vertex that sampled the direction).
    st.depth -= 1;
    if (!cross_null_surface(s, sh, st.ray, st.medium, st.null_crossings)) st.active = false;
    return;
  }
  st.nee_only = false;
  st.null_crossings = 0;
  if (st.depth >= pp.max_depth) { st.active = false; return; }

  if (vertex) vertex->sh = sh;  // before surface_material's normal mapping
  const Material m = surface_material(s, sh);
  Frame frame = shading_frame(s, sh, m);
  Vec3f wo = frame.to_local(wo_world);

  // All rays leaving this vertex on the side of wo start from one point p_front,
  // offset off the surface, and NEE measures light densities from that same
  // point; so the light pdf that MIS evaluates for a BSDF-sampled hit (from
  // prev_p, the ray origin) matches what NEE would have used for that direction.
  Vec3f p_front = offset_ray_origin(sh.p, sh.ng, wo_world);
  if (vertex && !material_is_delta(m)) {
    vertex->wo = wo_world;
    vertex->beta = st.beta;
    vertex->medium = st.medium;
    vertex->volume = false;
    vertex->valid = true;
  }

  // Next-event estimation: a path of depth + 1 segments.
  // One 2D sample chooses the light (u.x, then remapped) and the point on it.
  Vec2f u_light2 = st.sampler.next_2d();
  if (s.num_lights > 0 && !material_is_delta(m)) {
    float pmf;
    LightSample ls;
    if (path_light_sample(s, pp, p_front, u_light2, ls, pmf)) {
      Vec3f wi = frame.to_local(ls.wi);
      RGB f = bsdf_eval(m, wo, wi);
      if (!is_black(f)) {
        float w = 1.f;
        if (!ls.delta) w = power_heuristic(pmf * ls.pdf, bsdf_pdf(m, wo, wi));
        sr.contrib = st.beta * f * ls.Li * (abs_cos_theta(wi) * w / (pmf * ls.pdf));
        // Light behind the surface (transmission): start on the other side. The shadow ray is in the medium
        // of the side it leaves on (a medium boundary's, else the path's).
        const bool same_side = dot(ls.wi, sh.ng) * dot(wo_world, sh.ng) > 0.f;
        Vec3f o = same_side ? p_front : offset_ray_origin(sh.p, sh.ng, ls.wi);
        path_shadow_ray_to(sr, o, ls);
        sr.medium = medium_after_crossing(prim_medium_interface(s, sh.prim), ls.wi, sh.ng, st.medium);
        sr.active = !is_black(sr.contrib) && isfinite3(sr.contrib);
      }
    }
  }

  // BSDF sampling for the next segment.
  // The lobe choice and Russian roulette share one 2D point (one scrambled
  // Sobol pair instead of two 1D draws).
  Vec2f u_lobe_rr = st.sampler.next_2d();
  float u_lobe = u_lobe_rr.x, u_rr = u_lobe_rr.y;
  Vec2f u_bsdf = st.sampler.next_2d();
  BSDFSample bs;
  if (!bsdf_sample(m, wo, u_lobe, u_bsdf, bs)) { st.active = false; return; }
  Vec3f wi_world = frame.to_world(bs.wi);
  // Reject samples whose shading-normal side disagrees with the geometric side.
  if (dot(wi_world, sh.ng) * bs.wi.z * dot(sh.ns, sh.ng) < 0.f) { st.active = false; return; }
  st.beta *= bs.weight;
  st.eta_scale *= bs.eta * bs.eta;
  st.prev_pdf = bs.pdf;
  st.prev_delta = bs.delta;
  // The next ray is in the medium on the side it leaves (for a medium boundary: by that side, after a
  // reflection too, as pbrt-v4's GetMedium and Mitsuba 3's target_medium decide).
  st.medium = medium_after_crossing(prim_medium_interface(s, sh.prim), wi_world, sh.ng, st.medium);
  st.ray.o = dot(wi_world, sh.ng) * dot(wo_world, sh.ng) > 0.f ? p_front : offset_ray_origin(sh.p, sh.ng, wi_world);
  st.ray.d = wi_world;
  st.ray.tmax = kInf;
  st.prev_p = st.ray.o;
  path_roulette(pp, st, u_rr);
}

CHD void path_shadow(PathState& st, const ShadowRay& sr, bool occluded) {
  if (sr.active && !occluded) st.L += sr.contrib;
}
// The same with the shadow ray's transmittance (path_shadow_transmittance).
CHD void path_shadow(PathState& st, const ShadowRay& sr, RGB transmittance) {
  if (sr.active) st.L += sr.contrib * transmittance;
}

// One vertex of a path whose ray has been traced to `hit`: path_shade, then its shadow ray through
// `accel` (any type with intersect(Ray, Hit&) and occluded(Ray)). Counts the shadow ray in `shadow_rays`.
// CPU drivers only.
template <typename Accel>
inline void path_vertex(const SceneView& s, const PathParams& pp, const Accel& accel, PathState& st, const Hit& hit,
                        uint64_t& shadow_rays) {
  ShadowRay sr, eq;
  path_shade(s, pp, st, hit, sr, scene_wants_equiangular(s) ? &eq : nullptr);
  if (sr.active) {
    ++shadow_rays;
    path_shadow(st, sr, path_shadow_transmittance(s, accel, sr));
  }
  if (eq.active) {
    ++shadow_rays;
    path_shadow(st, eq, path_shadow_transmittance(s, accel, eq));
  }
}

// A whole camera path, one stage after another (the CPU's scalar driver). Counts closest-hit queries in
// `rays` and occlusion queries in `shadow_rays`.
template <typename Accel>
inline void path_trace(const SceneView& s, const PathParams& pp, const Accel& accel, uint32_t px, uint32_t py,
                       uint32_t sample_index, PathState& st, uint64_t& rays, uint64_t& shadow_rays) {
  path_start(s, pp, px, py, sample_index, st);
  while (st.active) {
    Hit hit;
    accel.intersect(st.ray, hit);
    ++rays;
    path_vertex(s, pp, accel, st, hit, shadow_rays);
  }
}

}  // namespace caustica
