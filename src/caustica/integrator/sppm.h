// Stage functions of stochastic progressive photon mapping shared by the CPU driver (photon_render.cpp) and
// the wavefront driver (wavefront_photon.h) on every backend:
//   trace_camera   a camera ray through specular bounces to its visible point, with emission and NEE on
//                  the way (Hachisuka & Jensen 2009, Sec. 4: a new visible point per pixel per pass)
//   sppm_gather    the photons within a radius of a visible point, weighted by its BSDF (the sum in
//                  Hachisuka et al. 2008 Eq. 6 / Knaus & Zwicker 2011 Eq. 3's numerator)
//   pppm_add       one pass's estimate with the global radius (Knaus & Zwicker 2011 Eq. 3)
//   trace_measurement_points  ppm's fixed points of a pixel (Hachisuka et al. 2008, Sec. 4.1), traced once
//   sppm_update    the progressive statistics (Hachisuka et al. 2008 Eqs. 6-11, shared per pixel in
//                  Hachisuka & Jensen 2009 Eqs. 5-8): N += alpha M, R and tau scaled by (N + alpha M)/(N + M)
//   sppm_volume_gather, pppm_add_volume, pppm_volume_radius  volumetric photon mapping in pppm and sppm
//                  (below)
//
// Participating media (pppm and sppm, on the CPU and wavefront drivers; volumetric photon mapping, Jensen &
// Christensen 1998, with Knaus & Zwicker 2011's global radius in pppm, and in sppm per-pixel statistics of
// their own for volume visible points, sppm_update with dims 3): the camera ray samples a free-flight
// distance on each segment in a medium (medium/medium.h, as the path tracer does). A scattering event there ends it at a volume visible
// point x: NEE with the phase function adds single scattering, and the volume photons within radius r of x
// (photon/trace.h, stored with power beta T sigma_s / p(t), the direct ones left out as on surfaces) estimate
// the rest of sigma_s(x) int p(wo, wi) L(x, wi) dwi as sum p(wo, wi_j) power_j / (N_emitted 4/3 pi r^3)
// (Jensen & Christensen 1998's volume radiance estimate, the "point query, 3D blur" of Jarosz et al. 2011,
// "A Comprehensive Theory of Volumetric Radiance Estimation", with sigma_s folded into the photons' power
// and the uniform kernel of radius r in place of the k nearest). The camera weight at x is T(t) / p(t) without sigma_s. Reaching a
// surface, the ray carries T / P(surface) and continues as without media; null surfaces are crossed without
// a segment; NEE at surface points is attenuated by the media on the shadow ray (shadow_transmittance).
#pragma once
#include "../base/sampler.h"
#include "../light/light_sample.h"
#include "../material/bsdf.h"
#include "../medium/medium_scene.h"
#include "../photon/hash_grid.h"
#include "../scene/shading.h"

namespace caustica {

struct VisiblePoint {
  Vec3f p, ng, ns, wo;  // wo in world space
  Vec3f tangent{0.f};    // shading_tangent: anisotropic roughness's direction (zero: isotropic)
  RGB beta{0.f};        // camera throughput to the point
  Material material;     // with its textures applied at the point
  bool valid = false;
  // A volume visible point (a scattering event of the camera ray in medium `medium`, header comment): p is
  // the event, wo towards the camera, beta without the medium's sigma_s; ng, ns, tangent, material unused.
  bool volume = false;
  // The medium the camera ray arrived in (-1: vacuum or a scene without media); at a surface point also its
  // primitive (-1 at volume points), whose medium interface gives the medium a ray leaving it enters (pm.h's
  // final gathering).
  int32_t medium = -1;
  int32_t prim = -1;
  // Segments from the camera to the point (the camera segment is 1): its photons may have at most
  // max_depth - depth (photon.h's photon_budget).
  uint32_t depth = 0;
};

// Follows a camera ray through specular bounces to the first non-specular
// surface, adding emission seen along the way (no MIS: the specular chain has no
// light-sampling alternative) and NEE at the visible point, its light chosen by power or, with light_bvh, by
// the light BVH's importance from the point (light/light_bvh.h). Returns the point. In scenes with media the
// ray starts in the camera's medium (or in `start_medium` unless that is kCameraMedium) and may end at a
// volume visible point instead (header comment). With `direct` false it adds nothing to L and draws no light
// samples: pm.h's final-gather rays find their point this way (the light they would add is the camera
// point's NEE and caustic map). With hide_emitters the emitters at the end of the camera segment add nothing
// (PathParams::hide_emitters).
constexpr int32_t kCameraMedium = -2;
template <typename Tracer>
CHD_ALWAYS_INLINE VisiblePoint trace_camera(const SceneView& s, const Tracer& accel, Ray ray, RGB beta,
                                            Sampler& smp, uint32_t max_depth, RGB& L, bool light_bvh = false,
                                            bool direct = true, int32_t start_medium = kCameraMedium,
                                            bool hide_emitters = false) {
  VisiblePoint vp;
  const bool media = scene_has_media(s);
  int32_t medium = !media ? -1 : start_medium == kCameraMedium ? s.camera_medium : start_medium;
  int32_t hero = -1;
  RGB r_medium(1.f);
  uint32_t null_crossings = 0;
  for (uint32_t depth = 1; depth <= max_depth; ++depth) {
    Hit hit;
    const bool found = accel.intersect(ray, hit);
    if (medium >= 0) {
      const Medium& md = s.media[medium];
      const float dlen = length(ray.d);
      const Vec3f d = ray.d / dlen;
      const uint64_t track_seed = md.grid >= 0 ? smp.stream_seed() : 0;
      const Vec2f u_m = smp.next_2d();
      if (hero < 0) hero = medium_hero_channel(u_m.x);
      MediumSample ms = medium_sample(s, md, ray.o, d, found ? hit.t * dlen : kInf, hero, u_m.y, track_seed);
      // At a scattering event the camera carries T / p without sigma_s: the volume photons' power holds it.
      if (ms.scattered) ms.f = ms.Tf;
      if (!medium_update_throughput(ms, beta, r_medium)) return vp;
      if (ms.scattered) {
        const Vec3f x = ray.o + d * ms.t;
        const RGB w = beta;
        if (direct && depth < max_depth && s.num_lights > 0) {
          // Single scattering by NEE with the phase function (volume photons of the first event are not
          // stored).
          float pmf = 0.f;
          const float u_l = smp.next_1d();
          const Vec2f u_l2 = smp.next_2d();
          Vec2f u_choice(u_l, 0.f);
          const int32_t li = choose_light(s, light_bvh, x, u_choice, pmf);
          LightSample ls;
          if (li >= 0 && sample_light(s, s.lights[li], x, u_l2, ls)) {
            const float ph = hg_phase(dot(-d, ls.wi), md.g);
            const Ray sray = std::isfinite(ls.dist) ? spawn_ray_to(x, ls.p_l, ls.n_l) : Ray{x, ls.wi, kInf};
            const RGB c = w * ms.sigma_s * ls.Li * (ph / (pmf * ls.pdf));
            if (!is_black(c)) L += c * shadow_transmittance(s, accel, sray, medium);
          }
        }
        vp.p = x;
        vp.ng = vp.ns = -d;
        vp.wo = -d;
        vp.beta = w;
        vp.volume = true;
        vp.medium = medium;
        vp.depth = depth;
        vp.valid = depth < max_depth;
        return vp;
      }
      if (is_black(beta)) return vp;
    }
    if (!found) {
      if (direct && s.environment_light >= 0 && !(hide_emitters && depth == 1))
        L += beta * environment_radiance(s, s.lights[s.environment_light], ray.d);
      return vp;
    }
    SurfaceHit sh = make_surface_hit(s, ray, hit);
    if (media && is_null_surface(s, sh)) {
      // Crossed unchanged into the medium behind it; not a segment.
      if (!cross_null_surface(s, sh, ray, medium, null_crossings)) return vp;
      --depth;
      continue;
    }
    null_crossings = 0;
    Vec3f wo_world = -ray.d;
    beta *= segment_transmittance(s, ray.d, hit.t, sh);
    if (direct && sh.light >= 0 && !(hide_emitters && depth == 1))
      L += beta * area_radiance(s, s.lights[sh.light], sh.ng, wo_world, sh.uv);
    const Material m = surface_material(s, sh);
    Frame frame = shading_frame(s, sh, m);
    Vec3f wo = frame.to_local(wo_world);
    float u_l = 0.f;
    Vec2f u_l2(0.f, 0.f);
    if (direct) {
      u_l = smp.next_1d();
      u_l2 = smp.next_2d();
    }
    if (!material_is_delta(m)) {
      // Direct light by NEE (photons of the first hit are not stored).
      if (direct && depth < max_depth && s.num_lights > 0) {
        float pmf = 0.f;
        Vec3f p_front = offset_ray_origin(sh.p, sh.ng, wo_world);
        Vec2f u_choice(u_l, 0.f);
        const int32_t li = choose_light(s, light_bvh, p_front, u_choice, pmf);
        LightSample ls;
        if (li >= 0 && sample_light(s, s.lights[li], p_front, u_l2, ls)) {
          RGB f = bsdf_eval(m, wo, frame.to_local(ls.wi));
          if (!is_black(f)) {
            Vec3f o = dot(ls.wi, sh.ng) * dot(wo_world, sh.ng) > 0.f ? p_front : offset_ray_origin(sh.p, sh.ng, ls.wi);
            Ray sray;
            if (std::isfinite(ls.dist)) sray = spawn_ray_to(o, ls.p_l, ls.n_l);
            else sray = Ray{o, ls.wi, kInf};
            const RGB c = beta * f * ls.Li * (abs_cos_theta(frame.to_local(ls.wi)) / (pmf * ls.pdf));
            if (!media) {
              if (!accel.occluded(sray)) L += c;
            } else {
              // The shadow ray is in the medium of the side it leaves on.
              const int32_t sm = medium_after_crossing(prim_medium_interface(s, sh.prim), ls.wi, sh.ng, medium);
              L += c * shadow_transmittance(s, accel, sray, sm);
            }
          }
        }
      }
      vp.p = sh.p;
      vp.ng = sh.ng;
      vp.ns = sh.ns;
      vp.tangent = shading_tangent(s, sh, m);
      vp.wo = wo_world;
      vp.beta = beta;
      vp.material = m;
      vp.medium = medium;
      vp.prim = int32_t(sh.prim);
      vp.depth = depth;
      vp.valid = depth < max_depth;  // a photon adds at least one more segment
      return vp;
    }
    BSDFSample bs;
    float uc = smp.next_1d();
    Vec2f u = smp.next_2d();
    if (!bsdf_sample(m, wo, uc, u, bs)) return vp;
    Vec3f wi = frame.to_world(bs.wi);
    beta *= bs.weight;
    if (media) medium = medium_after_crossing(prim_medium_interface(s, sh.prim), wi, sh.ng, medium);
    ray.o = offset_ray_origin(sh.p, sh.ng, wi);
    ray.d = wi;
    ray.tmax = kInf;
  }
  return vp;
}

// PPM's measurement points (Hachisuka et al. 2008, Sec. 4.1), traced once, on the first pass: the camera ray
// through every specular branch, splitting at dielectrics into reflection and refraction weighted by their
// Fresnel probabilities, so a pixel's fixed points carry the exact specular weights; up to `cap` points
// (kPpmPointsPerPixel), deepest branches dropped. Returns how many were written to out[0, cap); the caller
// marks the rest invalid. No random numbers: the points depend on the camera ray alone.
// In scenes with media the branches start in the camera's medium, cross null surfaces without a segment and
// carry the transmittance of every segment in a medium (no free-flight sampling: a fixed point stands for
// the camera rays that reach the surface, weight T; the rays that scatter before it are the per-pass volume
// visible points of trace_camera, header comment). A grid medium's transmittance is a ratio-tracking
// estimate drawn from `salt` (medium_segment_transmittance): ppm traces its points again every pass with the
// pass as salt, so the points stay where they are (nothing else depends on it) and their weights average to
// the exact T over the passes. Points are kept whatever their weight, so a pixel's k-th point is the same
// point in every pass; a branch ends where its specular weight alone (w, no transmittance: the same in every
// pass) is zero, as a chord of internal reflections in a glass sphere does after some 30 bounces in floats
// (it would go on forever with an unbounded depth).
constexpr int kPpmPointsPerPixel = 8;

template <typename Tracer>
CHD int trace_measurement_points(const SceneView& s, const Tracer& accel, Ray ray, uint32_t max_depth,
                                 VisiblePoint* out, int cap, uint64_t salt = 0) {
  struct Item {
    Ray ray;
    RGB beta, w;  // the weight, and its specular factor alone
    uint32_t depth;
    int32_t medium;
  };
  const bool media = scene_has_media(s);
  Item stack[16];
  int sp = 0, n = 0;
  stack[sp++] = Item{ray, RGB(1.f), RGB(1.f), 1u, media ? s.camera_medium : -1};
  uint32_t null_crossings = 0;
  while (sp > 0 && n < cap) {
    Item it = stack[--sp];
    Hit hit;
    const bool found = accel.intersect(it.ray, hit);
    if (!found) {
      null_crossings = 0;
      continue;
    }
    if (it.medium >= 0) {
      const float dlen = length(it.ray.d);
      it.beta *= medium_segment_transmittance(s, s.media[it.medium], it.ray.o, it.ray.d / dlen, hit.t * dlen, salt);
    }
    SurfaceHit sh = make_surface_hit(s, it.ray, hit);
    if (media && is_null_surface(s, sh)) {
      // Crossed into the medium behind it, the same branch at the same depth (on top of the stack, so the
      // count of crossings belongs to it).
      if (cross_null_surface(s, sh, it.ray, it.medium, null_crossings)) stack[sp++] = it;
      else null_crossings = 0;
      continue;
    }
    null_crossings = 0;
    const RGB absorbed = segment_transmittance(s, it.ray.d, hit.t, sh);  // Beer-Lambert inside glass (exact)
    it.beta *= absorbed;
    it.w *= absorbed;
    const Material m = surface_material(s, sh);
    Vec3f wo_world = -it.ray.d;
    if (!material_is_delta(m)) {
      if (it.depth < max_depth) {
        VisiblePoint& vp = out[n++];
        vp.p = sh.p;
        vp.ng = sh.ng;
        vp.ns = sh.ns;
        vp.tangent = shading_tangent(s, sh, m);
        vp.wo = wo_world;
        vp.beta = it.beta;
        vp.material = m;
        vp.medium = it.medium;
        vp.prim = int32_t(sh.prim);
        vp.depth = it.depth;
        vp.valid = true;
      }
      continue;
    }
    if (it.depth >= max_depth) continue;
    Frame frame = shading_frame(s, sh, m);
    Vec3f wo = frame.to_local(wo_world);
    // The two discrete choices of a delta BSDF: lobe sample u = 0 (reflection) and u -> 1 (transmission);
    // each branch carries weight x probability.
    BSDFSample a, b;
    bool ha = bsdf_sample(m, wo, 0.f, Vec2f(0.5f, 0.5f), a);
    bool hb = bsdf_sample(m, wo, kOneMinusEpsilon, Vec2f(0.5f, 0.5f), b);
    if (hb && ha && length_sq(a.wi - b.wi) < 1e-12f) hb = false;  // one lobe only (mirror)
    const BSDFSample* ch[2] = {ha ? &a : nullptr, hb ? &b : nullptr};
    for (const BSDFSample* c : ch) {
      if (!c || sp >= 16) continue;
      Vec3f wi = frame.to_world(c->wi);
      const float p = ch[0] && ch[1] ? c->pdf : 1.f;
      const RGB w = it.w * c->weight * p;
      if (is_black(w)) continue;
      const int32_t medium =
          media ? medium_after_crossing(prim_medium_interface(s, sh.prim), wi, sh.ng, it.medium) : -1;
      stack[sp++] =
          Item{Ray{offset_ray_origin(sh.p, sh.ng, wi), wi, kInf}, it.beta * c->weight * p, w, it.depth + 1, medium};
    }
  }
  return n;
}

// Sums f(wo, wi) * power over the photons of `grid` within `radius` of the point (photons on the far side of
// a thin wall arrive from below its surface and are filtered by the one-sided BSDF); M counts them. Only the
// photons that close a path of at most max_depth segments count (photon.h's photon_budget).
CHD void sppm_gather(const VisiblePoint& vp, const PhotonGridView& grid, float radius, uint32_t max_depth,
                     double phi[3], uint32_t& M) {
  const Material& m = vp.material;
  const Frame frame = tangent_frame(vp.ns, vp.tangent);
  Vec3f wo = frame.to_local(vp.wo);
  const uint32_t budget = photon_budget(max_depth, vp.depth);
  phi[0] = phi[1] = phi[2] = 0.0;
  M = 0;
  grid.query(vp.p, radius, [&](const Photon& ph) {
    if (photon_segments(ph) > budget) return;
    RGB f = bsdf_eval(m, wo, frame.to_local(ph.wi), TransportMode::kRadiance);
    ++M;
    for (int c = 0; c < 3; ++c) phi[c] += double(f[c]) * ph.power[c];
  });
}

// Hachisuka & Jensen 2009 Eqs. 5-8 (Hachisuka et al. 2008 Eqs. 6-11) after M > 0 photons with flux sum
// beta * phi: the new photon count N, the flux tau and the radius R of one visible point. `dims` 3 is the
// same update for a volume visible point (sppm in media, below): the photon density is per volume, so the
// kernel's volume 4/3 pi R^3 (not its area pi R^2) shrinks by the ratio (N + alpha M) / (N + M) that keeps
// the density estimate of Hachisuka et al.'s derivation (their Eq. 7 with the ball for the disc), i.e.
// R^3 by the ratio.
CHD void sppm_update(double& N, double* tau, float& R, const RGB& beta, const double phi[3], uint32_t M,
                     float alpha, int dims = 2) {
  if (M == 0) return;
  double Nn = N + double(alpha) * double(M);
  double ratio = Nn / (N + double(M));
  for (int c = 0; c < 3; ++c) tau[c] = (tau[c] + double(beta[c]) * phi[c]) * ratio;
  N = Nn;
  R = float(R * (dims == 3 ? std::cbrt(ratio) : std::sqrt(ratio)));
}

// Knaus & Zwicker 2011 Eq. 3 (one pass's estimate with the pass's global radius r), added to the pixel's
// sum over passes: beta * phi / (pi r^2 N_emitted).
CHD void pppm_add(double* indirect, const RGB& beta, const double phi[3], double inv_emitted, float radius) {
  double k = inv_emitted / (double(kPi) * double(radius) * radius);
  for (int c = 0; c < 3; ++c) indirect[c] += double(beta[c]) * phi[c] * k;
}

// Knaus & Zwicker 2011 Eq. 15 with i = 1, 2, ...: r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1); the radius of
// pass `abs_pass` (0-based) from the initial radius r0.
inline float pppm_radius(float r0, float alpha, int64_t abs_pass) {
  double r2 = double(r0) * r0;
  for (int64_t i = 1; i <= abs_pass; ++i) r2 *= (double(i) + alpha) / double(i + 1);
  return float(std::sqrt(r2));
}

// Volumetric photon mapping (header comment): the sum of p(wo, wi) * power over the volume photons of
// `grid` within `radius` of the volume visible point that close a path of at most max_depth segments; M
// counts them.
CHD void sppm_volume_gather(const VisiblePoint& vp, const SceneView& s, const PhotonGridView& grid, float radius,
                            uint32_t max_depth, double phi[3], uint32_t& M) {
  const float g = s.media[vp.medium].g;
  const uint32_t budget = photon_budget(max_depth, vp.depth);
  phi[0] = phi[1] = phi[2] = 0.0;
  M = 0;
  grid.query(vp.p, radius, [&](const Photon& ph) {
    if (photon_segments(ph) > budget) return;
    const double f = hg_phase(dot(vp.wo, ph.wi), g);
    ++M;
    for (int c = 0; c < 3; ++c) phi[c] += f * ph.power[c];
  });
}

// One pass's in-scattered radiance at a volume visible point, added to the pixel's sum over passes:
// beta * phi / (4/3 pi r^3 N_emitted) (the uniform kernel over the ball of radius r).
CHD void pppm_add_volume(double* indirect, const RGB& beta, const double phi[3], double inv_emitted, float radius) {
  const double k = inv_emitted / (4.0 / 3.0 * double(kPi) * double(radius) * radius * radius);
  for (int c = 0; c < 3; ++c) indirect[c] += double(beta[c]) * phi[c] * k;
}

// The volume photons' radius of pass `abs_pass`: Knaus & Zwicker 2011's Eq. 15 derivation with the 3D
// kernel's variance, which grows as r^-3 instead of r^-2 (their remark on volumetric photon mapping):
// r_{i+1}^3 = r_i^3 (i + alpha) / (i + 1), so the variance ratio per pass is again (i + 1) / (i + alpha).
inline float pppm_volume_radius(float r0, float alpha, int64_t abs_pass) {
  double r3 = double(r0) * r0 * r0;
  for (int64_t i = 1; i <= abs_pass; ++i) r3 *= (double(i) + alpha) / double(i + 1);
  return float(std::cbrt(r3));
}

}  // namespace caustica
