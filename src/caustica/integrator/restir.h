// ReSTIR DI: direct lighting by reservoir-based spatiotemporal importance resampling.
//
// Papers:
//  - Talbot, Cline & Egbert 2005, "Importance Resampling for Global Illumination" (resampled importance
//    sampling, RIS: M candidates from a source density p, one kept with probability proportional to
//    p_hat / p, weighted by (1 / p_hat(y)) * (1 / M) * sum of p_hat(x_i) / p(x_i)).
//  - Bitterli, Wyman, Pharr, Shirley, Lefohn & Jarosz 2020, "Spatiotemporal Reservoir Resampling for Real-Time
//    Ray Tracing with Dynamic Direct Lighting", ACM TOG 39(4) 148: RIS streamed through a one-sample weighted
//    reservoir, the reservoirs of the previous frame at the pixel (temporal reuse, its candidate count capped at
//    20x the frame's) and of k = 5 random neighbours within 30 pixels (spatial reuse, neighbours whose normals
//    differ by more than 25 degrees or whose depths differ by more than 10% skipped) resampled again; the
//    unbiased combination whose normalisation counts every input that could have produced the sample.
//  - Lin, Kettunen, Bitterli, Pantaleoni, Yuksel & Wyman 2022, "Generalized Resampled Importance Sampling:
//    Foundations of ReSTIR", ACM TOG 41(4) 75: resampling inputs from different domains with any partition of
//    unity as resampling MIS weights; here the (confidence-weighted) balance heuristic
//      m_i(y) = c_i p_hat_i(y) / sum_j c_j p_hat_j(y),
//    each input i resampled with weight w_i = m_i(y_i) p_hat_q(y_i) W_i, and W = sum_i w_i / p_hat_q(y).
//    (The papers' equation numbers were not checked; the formulas are written out here instead.)
//
// What caustica builds. The shading point of a pixel is the first vertex of its camera path with a non-delta
// BSDF (camera rays through glass and mirrors reach it by the path tracer's sampled specular bounces). Its
// direct light is estimated by ReSTIR; everything else - emitters seen directly or through specular bounces,
// and the light of the longer paths - by the path tracer (path.h), which continues from the shading point
// with a BSDF sample whose emission hit is not added again (PathState::nee_only: the direct light at the
// shading point comes from light sampling alone, as the NEE-only estimator does, so no MIS is needed there).
//
// The sample domain is shared by every pixel: a light of the scene and, for area lights, a point on it (area
// measure), for the environment a direction (solid-angle measure), for point, spot and directional lights the
// light itself (counting measure). Candidates come from the path tracer's light sampling (power-proportional
// choice, then sample_light) with their density converted to that measure; the target p_hat_q(y) is the
// luminance of the unshadowed contribution beta * f * Le * |cos| * J (J = |cos_l| / d^2 on area lights,
// 1 / d^2 folded into a point light's Li, 1 elsewhere), beta the throughput from the camera to q. The final
// estimate traces one shadow ray: beta f Le |cos| J V W. Every reservoir input's W is an unbiased contribution
// weight for its own target, whose support (p_hat > 0) is exactly where its candidates' density is positive
// (restir_contribution refuses the back of a sphere light, which cone sampling cannot reach); with the
// balance heuristic over all inputs that could have produced y, each pass is an unbiased estimate of the
// direct light (GRIS), whatever the correlation between the inputs. Visibility is not in the target, so no
// bias from a visibility-reuse shortcut is taken.
//
// Participating media. The camera path samples free-flight distances as the path tracer's (path_shade), so the
// shading point is its first vertex where the path tracer would sample a light: a non-delta surface or a
// scattering event in a medium (a volume shading point, throughput with sigma_s, the phase function in the
// BSDF's place, no cosine: the target p_hat(y) = lum(beta p(wo, wi) Le J)). The shadow ray of the final
// estimate carries the transmittance of the media it crosses, through null surfaces (shadow_transmittance;
// ratio tracking in grid media, an unbiased estimate): like visibility it is left out of the target, so the
// estimate stays unbiased. Spatial and temporal reuse combine only shading points of one kind (surface with
// surface, volume with volume), which like the normal test looks at shading points alone. The path goes on
// from a volume shading point with a phase sample whose emitters are not added again (nee_only, cleared at
// the next vertex: a surface or another scattering event, not a null surface). Emissive media add their
// emission along the path as in the path tracer (collisions, no light sampling), outside ReSTIR.
//
// Stage functions, host/device like the path tracer's: restir_primary and restir_spatial are one pixel's work
// in the two per-pass stages of the driver (integrator/wavefront_restir.h), which runs on the CPU backend
// (the default, and --wavefront) and on CUDA from this one source.
#pragma once
#include "../base/rng.h"
#include "path.h"

namespace caustica {

struct RestirParams {
  uint32_t candidates = 32;  // M: light samples per pixel and pass (Bitterli et al. 2020 use 32)
  uint32_t neighbors = 5;    // k: spatial neighbours per pixel and pass (0: no spatial reuse)
  float radius = 30.f;       // spatial reuse radius, pixels
  float history = 20.f;      // temporal reuse: the previous pass's confidence capped at history * M (0: none)
};

// A point of the shared light domain (see the header comment).
struct LightPoint {
  Vec3f p;          // area lights: the point; point/spot: unused; environment: the direction towards the sky
  Vec3f n;          // area lights: the geometric normal
  Vec2f uv;         // area lights: texture coordinates (emission textures)
  int32_t light = -1;
};

// The pixel's shading point as stored between stages and passes.
struct RestirVertex {
  SurfaceHit sh;     // as made by make_surface_hit (before normal mapping); a volume point: sh.p only
  Vec3f wo;          // towards the camera, world space
  RGB beta{0.f};     // throughput from the camera (pixel filter weight excluded)
  float depth = 0.f; // path length from the camera (spatial reuse's similarity test)
  int32_t medium = -1;  // the medium the camera path arrived in (-1: vacuum)
  bool volume = false;  // a scattering event in that medium (header comment)
  bool valid = false;
};

// A one-sample reservoir: the sample y, its unbiased contribution weight W, its confidence c (candidates it
// stands for) and its target at its own shading point.
struct Reservoir {
  LightPoint y;
  float w_sum = 0.f;
  float W = 0.f;
  float c = 0.f;
  float p_hat = 0.f;
  CHD bool has_sample() const { return y.light >= 0 && W > 0.f; }
  // Weighted reservoir sampling with one slot: x replaces the sample with probability w / w_sum.
  CHD bool update(const LightPoint& x, float w, float p_hat_x, float u) {
    if (!(w > 0.f) || !(w < kInf)) return false;
    w_sum += w;
    if (u * w_sum < w) {
      y = x;
      p_hat = p_hat_x;
      return true;
    }
    return false;
  }
  // W = w_sum / p_hat_q(y) once all inputs are in.
  CHD void finish() {
    W = p_hat > 0.f ? w_sum / p_hat : 0.f;
    if (!(W > 0.f) || !(W < kInf)) {
      W = 0.f;
      y.light = -1;
    }
  }
};

// What the target needs at a shading point, computed once per vertex and stage.
struct RestirShading {
  Material m;
  Frame frame;
  Vec3f wo;       // local
  Vec3f wo_world;
  Vec3f p, ng;
  Vec3f p_front;  // the shadow rays' (and light densities') reference point on wo's side
  RGB beta{0.f};
  float depth = 0.f;
  float g = 0.f;        // a volume point's phase function asymmetry
  int32_t medium = -1;  // RestirVertex's
  uint32_t prim = 0;    // a surface point's primitive (its medium interface)
  bool volume = false;
  bool valid = false;
};

CHD RestirShading restir_shading(const SceneView& s, const RestirVertex& v) {
  RestirShading r;
  if (!v.valid) return r;
  r.medium = v.medium;
  if (v.volume) {
    r.volume = true;
    r.g = s.media[v.medium].g;
    r.wo_world = v.wo;
    r.p = r.p_front = v.sh.p;
    r.beta = v.beta;
    r.depth = v.depth;
    r.valid = true;
    return r;
  }
  SurfaceHit sh = v.sh;
  r.prim = sh.prim;
  r.m = surface_material(s, sh);
  r.frame = shading_frame(s, sh, r.m);
  r.wo_world = v.wo;
  r.wo = r.frame.to_local(v.wo);
  r.p = sh.p;
  r.ng = sh.ng;
  r.p_front = offset_ray_origin(sh.p, sh.ng, v.wo);
  r.beta = v.beta;
  r.depth = v.depth;
  r.valid = true;
  return r;
}

// How shading point v scatters light arriving from wi (world) towards the camera, as f * c: on a surface the
// BSDF f and c = |cos theta|, at a volume point f = 1 and c the phase function (no cosine). Callers multiply
// beta * f * Le * (c * J) in that order.
CHD float restir_scatter(const RestirShading& v, Vec3f wi, RGB& f) {
  if (v.volume) {
    f = RGB(1.f);
    return hg_phase(dot(v.wo_world, wi), v.g);
  }
  const Vec3f wl = v.frame.to_local(wi);
  f = bsdf_eval(v.m, v.wo, wl);
  return abs_cos_theta(wl);
}

// The unshadowed contribution of light point y at shading point v per unit of y's measure (0 where v's
// candidates cannot reach y); wi and dist give the shadow ray's direction and length (kInf: distant).
CHD RGB restir_contribution(const SceneView& s, const RestirShading& v, const LightPoint& y, Vec3f& wi,
                            float& dist) {
  if (!v.valid || y.light < 0) return RGB(0.f);
  const Light& l = s.lights[y.light];
  RGB Le(0.f);
  float J = 1.f;
  switch (l.type) {
    case LightType::kTriangle:
    case LightType::kSphere: {
      Vec3f d = y.p - v.p_front;
      float d2 = length_sq(d);
      if (!(d2 > 0.f)) return RGB(0.f);
      dist = std::sqrt(d2);
      wi = d / dist;
      float cos_l = dot(y.n, wi);  // < 0: the light's front faces v
      if (l.type == LightType::kSphere) {
        bool inside;
        sphere_cos_theta_max(s.spheres[l.prim - s.num_triangles], v.p_front, inside);
        if (!inside && cos_l >= 0.f) return RGB(0.f);  // the far side: outside the cone sampling covers
      }
      if (cos_l == 0.f) return RGB(0.f);
      Le = area_radiance(s, l, y.n, -wi, y.uv) * area_coverage(s, l.prim, y.uv);
      J = std::fabs(cos_l) / d2;
      break;
    }
    case LightType::kPoint:
    case LightType::kSpot: {
      Vec3f d = l.p - v.p_front;
      float d2 = length_sq(d);
      if (!(d2 > 0.f)) return RGB(0.f);
      dist = std::sqrt(d2);
      wi = d / dist;
      float falloff = l.type == LightType::kSpot ? spot_falloff(l, dot(-wi, l.dir)) : 1.f;
      Le = l.L * falloff;
      J = 1.f / d2;
      break;
    }
    case LightType::kDirectional:
      wi = -l.dir;
      dist = kInf;
      Le = l.L;
      break;
    case LightType::kEnvironment:
      wi = y.p;
      dist = kInf;
      Le = environment_radiance(s, l, wi);
      break;
  }
  if (is_black(Le)) return RGB(0.f);
  RGB f;
  const float c = restir_scatter(v, wi, f);
  return v.beta * f * Le * (c * J);
}

CHD float restir_target(const SceneView& s, const RestirShading& v, const LightPoint& y) {
  Vec3f wi;
  float dist;
  RGB g = restir_contribution(s, v, y, wi, dist);
  float t = luminance(g);
  return t > 0.f && t < kInf ? t : 0.f;
}

// The shadow ray from shading point v to light point y (wi: restir_contribution's direction), leaving on
// wi's side of the surface (transmission: the other side), as the path tracer's next-event estimation.
CHD Ray restir_shadow_ray(const SceneView& s, const RestirShading& v, const LightPoint& y, Vec3f wi) {
  const Light& l = s.lights[y.light];
  Vec3f o = v.volume ? v.p : dot(wi, v.ng) * dot(v.wo_world, v.ng) > 0.f ? v.p_front : offset_ray_origin(v.p, v.ng, wi);
  if (l.type == LightType::kTriangle || l.type == LightType::kSphere) return spawn_ray_to(o, y.p, y.n);
  if (l.type == LightType::kPoint || l.type == LightType::kSpot) return spawn_ray_to(o, l.p, Vec3f(0.f));
  Ray r;
  r.o = o;
  r.d = wi;
  r.tmax = kInf;
  return r;
}

// The medium the shadow ray towards wi starts in: a volume point's own, or the one on wi's side of a surface
// (a medium boundary's, else the path's), as the path tracer's next-event estimation decides.
CHD int32_t restir_shadow_medium(const SceneView& s, const RestirShading& v, Vec3f wi) {
  if (v.volume || !scene_has_media(s)) return v.medium;
  return medium_after_crossing(prim_medium_interface(s, v.prim), wi, v.ng, v.medium);
}

// One light-sampling candidate at v: the point, its density in the domain's measure, and its unshadowed
// contribution g (restir_contribution's value, computed from the light sample without evaluating the light
// again; false: none). The light is chosen by power, or with light_bvh by the light BVH's importance from
// v.p_front (light/light_bvh.h): RIS needs only that the source density be positive wherever the target is,
// which the BVH's conservative bounds keep, and the reuse passes never re-evaluate it.
CHD bool restir_candidate(const SceneView& s, const RestirShading& v, bool light_bvh, Vec2f u, LightPoint& y,
                          float& pdf, RGB& g) {
  if (s.num_lights == 0) return false;
  float pmf = 0.f;
  const int32_t chosen = choose_light(s, light_bvh, v.p_front, u, pmf);
  if (chosen < 0) return false;
  const uint32_t li = uint32_t(chosen);
  const Light& l = s.lights[li];
  LightSample ls;
  if (!sample_light(s, l, v.p_front, u, ls)) return false;
  y.light = int32_t(li);
  float J = 1.f;  // point and spot lights: 1 / d^2 is in ls.Li
  switch (l.type) {
    case LightType::kTriangle:
    case LightType::kSphere: {
      y.p = ls.p_l;
      y.n = ls.n_l;
      y.uv = ls.uv_l;
      // Solid angle to area: dw = |cos_l| / d^2 dA.
      J = absdot(ls.n_l, ls.wi) / (ls.dist * ls.dist);
      pdf = pmf * ls.pdf * J;
      break;
    }
    case LightType::kEnvironment:
      y.p = ls.wi;
      pdf = pmf * ls.pdf;
      break;
    default:  // delta lights: the light itself
      pdf = pmf;
      break;
  }
  if (!(pdf > 0.f && pdf < kInf)) return false;
  RGB f;
  const float c = restir_scatter(v, ls.wi, f);
  g = v.beta * f * ls.Li * (c * J);
  return true;
}

// RIS over M light-sampling candidates at v (a reservoir of confidence M, even if none succeeded).
CHD Reservoir restir_initial(const SceneView& s, const RestirShading& v, uint32_t M, bool light_bvh, PCG32& rng) {
  Reservoir r;
  if (!v.valid) return r;
  for (uint32_t i = 0; i < M; ++i) {
    Vec2f u(rng.next_float(), rng.next_float());
    float u_pick = rng.next_float();
    LightPoint x;
    float pdf;
    RGB g;
    if (!restir_candidate(s, v, light_bvh, u, x, pdf, g)) continue;
    float ph = luminance(g);
    if (ph > 0.f && ph < kInf) r.update(x, ph / (float(M) * pdf), ph, u_pick);
  }
  r.c = float(M);
  r.finish();
  return r;
}

// Resamples n reservoirs into one for shading point v[0] (GRIS with the balance heuristic, header comment):
// in[i] belongs to shading point v[i] and enters with confidence c[i]. The output's confidence is sum c.
CHD Reservoir restir_combine(const SceneView& s, const RestirShading* const* v, const Reservoir* in, const float* c,
                             int n, PCG32& rng) {
  Reservoir out;
  for (int i = 0; i < n; ++i) {
    out.c += c[i];
    const Reservoir& r = in[i];
    float u = rng.next_float();
    if (!r.has_sample()) continue;
    float p_q = i == 0 ? r.p_hat : restir_target(s, *v[0], r.y);
    if (!(p_q > 0.f)) continue;
    float denom = 0.f;
    for (int j = 0; j < n; ++j) denom += c[j] * (j == i ? r.p_hat : j == 0 ? p_q : restir_target(s, *v[j], r.y));
    float m = denom > 0.f ? c[i] * r.p_hat / denom : 0.f;
    out.update(r.y, m * p_q * r.W, p_q, u);
  }
  out.finish();
  return out;
}

// What both stages of a pass need besides the scene.
struct RestirPass {
  PathParams pp;
  RestirParams rp;
  uint64_t seed = 0;
  uint32_t pass = 0;
  uint32_t width = 0, height = 0;
  bool temporal = false;  // the previous pass's history exists and is used
};

// Bitterli et al. 2020's neighbour test: normals within 25 degrees, distances from the camera within 10%; in
// media, points of one kind only (two volume points: the distances alone). It looks at shading points only
// (never at samples), so skipping a neighbour keeps the estimate unbiased.
CHD bool restir_similar(const RestirShading& a, const RestirShading& b) {
  if (!a.valid || !b.valid || a.volume != b.volume) return false;
  return (a.volume || dot(a.frame.n, b.frame.n) >= 0.906307787f) && std::fabs(a.depth - b.depth) <= 0.1f * a.depth;
}

constexpr uint64_t kRestirStageTemporal = 1, kRestirStageSpatial = 2;
constexpr int kRestirMaxNeighbors = 32;

// Stage 1 for one pixel: the camera path (path.h's stages through `tracer`) to its shading point, which is
// recorded in `v`, and on (emission, longer paths: L and the filter weight); RIS over the light candidates at
// the shading point, then temporal reuse of the previous pass's final reservoir at the pixel (prev_v, prev_r)
// into `out`. Counts closest-hit and shadow rays.
template <class Tracer>
CHD void restir_primary(const SceneView& s, const Tracer& tracer, const RestirPass& p, uint32_t px, uint32_t py,
                        const RestirVertex& prev_v, const Reservoir& prev_r, RestirVertex& v, Reservoir& out, RGB& L,
                        float& weight, uint32_t& rays, uint32_t& shadow_rays) {
  PathState st;
  path_start(s, p.pp, px, py, p.pass, st);
  const uint32_t pix = st.pixel;
  v = RestirVertex();
  float travelled = 0.f;
  while (st.active) {
    Hit hit;
    tracer.intersect(st.ray, hit);
    ++rays;
    ShadowRay sr;
    if (!v.valid) {
      // path_shade reports the vertex where it samples a light (PathVertex): the shading point.
      const Ray segment = st.ray;
      PathVertex pv;
      path_shade(s, p.pp, st, hit, sr, nullptr, &pv);
      if (pv.valid) {
        v.sh = pv.sh;
        v.wo = pv.wo;
        v.beta = pv.beta;
        v.depth = travelled + (pv.volume ? length(pv.sh.p - segment.o) / length(segment.d) : hit.t);
        v.medium = pv.medium;
        v.volume = pv.volume;
        v.valid = true;
        // Emission here and the BSDF (or phase) sample onwards as the path tracer; its light sample is not
        // traced (ReSTIR estimates the direct light here), and the emitters the sample reaches through a
        // non-delta lobe are left to ReSTIR too.
        st.nee_only = st.active && !st.prev_delta;
        continue;
      }
      if (hit.valid()) travelled += hit.t;
    } else {
      // Past the shading point the path tracer's own estimators, equiangular sampling of point and spot
      // lights in media included (not before: along the segments up to the shading point it would count
      // single scattering that ReSTIR estimates at a volume shading point).
      ShadowRay eq;
      path_shade(s, p.pp, st, hit, sr, scene_wants_equiangular(s) ? &eq : nullptr);
      if (eq.active) {
        ++shadow_rays;
        path_shadow(st, eq, path_shadow_transmittance(s, tracer, eq));
      }
    }
    if (sr.active) {
      ++shadow_rays;
      path_shadow(st, sr, path_shadow_transmittance(s, tracer, sr));
    }
  }
  L = st.L;
  weight = st.weight;

  PCG32 rng(kRestirStageTemporal, hash3(p.seed, p.pass, pix));
  RestirShading q = restir_shading(s, v);
  out = restir_initial(s, q, p.rp.candidates, p.pp.light_bvh, rng);
  if (p.temporal && q.valid) {
    RestirShading prev = restir_shading(s, prev_v);
    if (restir_similar(q, prev)) {
      const RestirShading* vs[2] = {&q, &prev};
      Reservoir in[2] = {out, prev_r};
      float c[2] = {out.c, minf(prev_r.c, p.rp.history * float(p.rp.candidates))};
      out = restir_combine(s, vs, in, c, 2, rng);
    }
  }
}

// Stage 2 for one pixel: spatial reuse of the stage-1 reservoirs (`temporal`, all pixels, finished) of up to k
// neighbours into `out` (the next pass's history), then one shadow ray to the resampled light point; adds the
// direct light to L.
template <class Tracer>
CHD void restir_spatial(const SceneView& s, const Tracer& tracer, const RestirPass& p, uint32_t px, uint32_t py,
                        const RestirVertex* vert, const Reservoir* temporal, Reservoir& out, RGB& L,
                        uint32_t& shadow_rays) {
  const uint32_t W = p.width, H = p.height, pix = py * W + px;
  PCG32 rng(kRestirStageSpatial, hash3(p.seed, p.pass, pix));
  RestirShading shade[1 + kRestirMaxNeighbors];
  const RestirShading* vs[1 + kRestirMaxNeighbors];
  Reservoir in[1 + kRestirMaxNeighbors];
  float c[1 + kRestirMaxNeighbors];
  shade[0] = restir_shading(s, vert[pix]);
  out = temporal[pix];
  if (shade[0].valid && p.rp.neighbors > 0) {
    int n = 1;
    vs[0] = &shade[0];
    in[0] = out;
    c[0] = out.c;
    const uint32_t k_max = p.rp.neighbors < uint32_t(kRestirMaxNeighbors) ? p.rp.neighbors : kRestirMaxNeighbors;
    for (uint32_t k = 0; k < k_max; ++k) {
      // A neighbour uniformly in the disk of the reuse radius around the pixel.
      Vec2f d = square_to_concentric_disk(Vec2f(rng.next_float(), rng.next_float())) * p.rp.radius;
      int nx = int(px) + int(std::floor(d.x + 0.5f)), ny = int(py) + int(std::floor(d.y + 0.5f));
      if (nx < 0 || ny < 0 || nx >= int(W) || ny >= int(H) || (nx == int(px) && ny == int(py))) continue;
      const uint32_t q = uint32_t(ny) * W + uint32_t(nx);
      shade[n] = restir_shading(s, vert[q]);
      if (!restir_similar(shade[0], shade[n])) continue;
      vs[n] = &shade[n];
      in[n] = temporal[q];
      c[n] = temporal[q].c;
      ++n;
    }
    if (n > 1) out = restir_combine(s, vs, in, c, n, rng);
  }
  if (!out.has_sample()) return;
  Vec3f wi;
  float dist = kInf;
  RGB g = restir_contribution(s, shade[0], out.y, wi, dist);
  if (is_black(g)) return;
  ++shadow_rays;
  // Visibility, and in media the transmittance (header comment).
  const RGB T = shadow_transmittance(s, tracer, restir_shadow_ray(s, shade[0], out.y, wi),
                                     restir_shadow_medium(s, shade[0], wi));
  if (!is_black(T)) L += g * out.W * T;
}

}  // namespace caustica
