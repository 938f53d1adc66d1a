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
#pragma once
#include "../base/sampler.h"
#include "../light/light_sample.h"
#include "../material/bsdf.h"
#include "../scene/shading.h"

namespace caustica {

struct PathParams {
  uint32_t max_depth = 0xffffffffu;  // segments; 0xffffffff: unlimited
  uint32_t rr_depth = 5;
  uint64_t seed = 0;
  SamplerType sampler = SamplerType::kSobol;
  bool jitter = true;  // false: every sample through the pixel centre, weight 1 (camera rays repeat per pass)
  bool light_bvh = false;  // choose lights by the light BVH (light/light_bvh.h) instead of by power alone
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
  uint32_t pixel = 0;
  Sampler sampler;
};

struct ShadowRay {
  Ray ray;
  RGB contrib{0.f};
  bool active = false;
};

CHD void path_start(const SceneView& s, const PathParams& pp, uint32_t px, uint32_t py, uint32_t sample_index,
                    PathState& st) {
  st = PathState();
  st.pixel = py * uint32_t(s.camera.width) + px;
  st.sampler.start(pp.sampler, pp.seed, st.pixel, sample_index);
  FilterSample fs = filter_sample(s.filter, st.sampler.next_2d());
  if (!pp.jitter) fs = FilterSample{Vec2f(0.f, 0.f), 1.f};
  // A pinhole camera takes no lens sample (and spends no dimension on one).
  Vec2f lens = s.camera.aperture_radius > 0.f ? st.sampler.next_2d() : Vec2f(0.5f, 0.5f);
  Vec2f film(float(px) + 0.5f + fs.offset.x, float(py) + 0.5f + fs.offset.y);
  // A moving camera takes a time in the shutter interval (a static one spends no dimension on it).
  st.ray = s.camera.moving ? s.camera.at(st.sampler.next_1d()).generate_ray(film, lens)
                           : s.camera.generate_ray(film, lens);
  st.prev_p = st.ray.o;
  st.weight = fs.weight;
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

CHD void path_shade(const SceneView& s, const PathParams& pp, PathState& st, const Hit& hit, ShadowRay& sr) {
  sr.active = false;
  st.depth += 1;  // the segment just traced
  if (!hit.valid()) {
    if (s.environment_light >= 0 && !st.nee_only) {
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
  st.beta *= segment_transmittance(s, st.ray.d, hit.t, sh);

  if (!st.nee_only) path_add_emission(s, pp, sh, wo_world, st.prev_p, st.prev_pdf, st.prev_delta, st.beta, st.L);
  st.nee_only = false;
  if (st.depth >= pp.max_depth) { st.active = false; return; }

  const Material m = surface_material(s, sh);
  Frame frame = shading_frame(s, sh, m);
  Vec3f wo = frame.to_local(wo_world);

  // All rays leaving this vertex on the side of wo start from one point p_front,
  // offset off the surface, and NEE measures light densities from that same
  // point; so the light pdf that MIS evaluates for a BSDF-sampled hit (from
  // prev_p, the ray origin) matches what NEE would have used for that direction.
  Vec3f p_front = offset_ray_origin(sh.p, sh.ng, wo_world);

  // Next-event estimation: a path of depth + 1 segments.
  // One 2D sample chooses the light (u.x, then remapped) and the point on it.
  Vec2f u_light2 = st.sampler.next_2d();
  if (s.num_lights > 0 && !material_is_delta(m)) {
    float pmf = 0.f;
    int32_t li = choose_light(s, pp.light_bvh, p_front, u_light2, pmf);
    LightSample ls;
    if (li >= 0 && sample_light(s, s.lights[li], p_front, u_light2, ls)) {
      Vec3f wi = frame.to_local(ls.wi);
      RGB f = bsdf_eval(m, wo, wi);
      if (!is_black(f)) {
        float w = 1.f;
        if (!ls.delta) w = power_heuristic(pmf * ls.pdf, bsdf_pdf(m, wo, wi));
        sr.contrib = st.beta * f * ls.Li * (abs_cos_theta(wi) * w / (pmf * ls.pdf));
        // Light behind the surface (transmission): start on the other side.
        Vec3f o = dot(ls.wi, sh.ng) * dot(wo_world, sh.ng) > 0.f ? p_front : offset_ray_origin(sh.p, sh.ng, ls.wi);
        if (std::isfinite(ls.dist)) {
          sr.ray = spawn_ray_to(o, ls.p_l, ls.n_l);
        } else {
          sr.ray.o = o;
          sr.ray.d = ls.wi;
          sr.ray.tmax = kInf;
        }
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
  st.ray.o = dot(wi_world, sh.ng) * dot(wo_world, sh.ng) > 0.f ? p_front : offset_ray_origin(sh.p, sh.ng, wi_world);
  st.ray.d = wi_world;
  st.ray.tmax = kInf;
  st.prev_p = st.ray.o;
  if (is_black(st.beta)) { st.active = false; return; }
  if (st.depth >= pp.rr_depth) {
    float q = minf(max_component(st.beta) * st.eta_scale, 0.95f);
    if (!(u_rr < q)) { st.active = false; return; }
    st.beta /= q;
  }
}

CHD void path_shadow(PathState& st, const ShadowRay& sr, bool occluded) {
  if (sr.active && !occluded) st.L += sr.contrib;
}

// One vertex of a path whose ray has been traced to `hit`: path_shade, then its shadow ray through
// `accel` (any type with occluded(Ray)). Counts the shadow ray in `shadow_rays`. CPU drivers only.
template <typename Accel>
inline void path_vertex(const SceneView& s, const PathParams& pp, const Accel& accel, PathState& st, const Hit& hit,
                        uint64_t& shadow_rays) {
  ShadowRay sr;
  path_shade(s, pp, st, hit, sr);
  if (sr.active) {
    ++shadow_rays;
    path_shadow(st, sr, accel.occluded(sr.ray));
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
