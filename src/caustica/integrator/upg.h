// Unbiased photon gathering (`upg`) as stage functions over vcm.h's BDPT stages.
//
// Paper: Qin, Sun, Hou, Guo, Zhou 2015, "Unbiased Photon Gathering for Light Transport
// Simulation", ACM TOG 34(6). A photon y_s (a stored light vertex) found within
// radius r of an eye vertex z_t makes a full path sample by dropping z_t and
// connecting y_s to the previous eye vertex z_{t-1}:
//   x = y_0 ... y_s z_{t-1} ... z_0.
// Given the two subpaths, the technique produced x exactly when the eye's
// sampling from z_{t-1} (its BSDF sample, and its Russian roulette) landed within r
// of y_s, an event of probability P(z_{t-1} -> B(y_s, r)) with no closed form. So
// the path density of gathering is p_light(y_0..y_s) p_eye(z_{t-1}..z_0) P, and
//   C = f(x) / (p_light p_eye P N_light)
// (N_light light subpaths are searched). 1/P is estimated without bias as in
// the paper: repeat the eye's sampling from z_{t-1} with fresh random numbers
// until a trial lands within r of y_s; the trial count N is geometric with
// success probability P, E[N] = 1/P. Trials are capped at kUpgMaxTrials (a
// capped N = 0 for the sample; a bias of relative size (1 - P)^cap, stated in
// docs/integrators.md). The landing test is the same |x - y_s| < r for the
// gathered eye vertex and for the trials (exact float positions, not the hash
// grid's quantized ones).
//
// MIS. A gathered path is also sampled by BDPT's connection of the same light
// vertex y_s and camera vertex z_{t-1}. Each BDPT strategy (s, t) keeps its
// weight w_bdpt from vcm.h (Georgiev 2012's recursive quantities in bdpt mode;
// every strategy, the pairs themselves included, weighs the others as BDPT
// does). The connection's share is split between the connection (one light
// subpath, density p_c = p_light p_eye) and the gather (N_light subpaths, density
// P p_c, P approximated as p_eye(z_{t-1} -> y_s) pi r^2 for the weights, as the
// paper does for its MIS): with g = mis(N_light pi r^2 p_eye,A(z_{t-1} -> y_s)),
//   connection: w_bdpt / (1 + g),   gather: w_bdpt g / (1 + g).
// Both estimators compute g from the same vertex pair, so the weights of all
// strategies still sum to one and the combination is unbiased (up to the cap).
// The gather runs at every eye hit z_t whose predecessor z_{t-1} is a non-delta
// surface vertex (never from the camera itself), for every stored photon within r.
//
// Cost control: the trials of a low-weighted gather are skipped by Russian
// roulette, survival q = min(1, kUpgRrScale * w_gather_share), dividing by q
// (unbiased). The expected trial count of a kept photon is 1/P.
#pragma once
#include "vcm.h"

namespace caustica {

constexpr uint32_t kUpgMaxTrials = 16384;
constexpr float kUpgRrScale = 4.f;

// eta = N_light pi r^2 (the gathering radius is fixed; p.radius set by vcm_set_radius).
CHD float upg_eta(const VcmParams& p) { return kPi * p.radius * p.radius * p.n_light; }

// mis(eta p_eye,A(z -> y)) for camera vertex `cam` (non-delta) and light vertex v:
// the gather's density relative to the connection's.
CHD float upg_gather_ratio(const SceneView& s, const VcmParams& p, const VcmPathState& cam, const VcmLightVertex& v) {
  (void)s;
  Vec3f d = v.sh.p - cam.sh.p;
  float d2 = length_sq(d);
  if (!(d2 > 0.f)) return 0.f;
  Vec3f w = d / std::sqrt(d2);
  float cos_l = absdot(v.sh.ns, w);
  float pdf_a = bsdf_pdf(cam.m, cam.wo, cam.frame.to_local(w)) * cos_l / d2;
  return vcm_mis(p, upg_eta(p) * pdf_a);
}

// BDPT connection of camera vertex `cam` with light vertex v, with upg's share
// taken out (its weight times 1 / (1 + g)).
CHD void upg_camera_connect(const SceneView& s, const VcmParams& p, const VcmPathState& cam, const VcmLightVertex& v,
                            VcmShadow& sr) {
  vcm_camera_connect(s, p, cam, v, sr);
  if (!sr.active) return;
  sr.contrib *= 1.f / (1.f + upg_gather_ratio(s, p, cam, v));
}

// One gathered photon v at the eye hit after `prev` (z_{t-1}, non-delta): the
// connection's contribution with the gather's MIS share and 1 / N_light, its
// shadow ray, and the roulette probability of running the trials. The caller
// traces the shadow ray, then multiplies by the trial count N / q.
struct UpgGather {
  VcmShadow conn;   // contrib: f / (p_light p_eye) w_bdpt g / (1 + g) / N_light
  float q = 0.f;    // probability of running the trials (Russian roulette)
  bool active = false;
};

CHD void upg_gather(const SceneView& s, const VcmParams& p, const VcmPathState& prev, const VcmLightVertex& v,
                    float u_rr, UpgGather& g) {
  g.active = false;
  vcm_camera_connect(s, p, prev, v, g.conn);
  if (!g.conn.active) return;
  float gr = upg_gather_ratio(s, p, prev, v);
  float share = gr / (1.f + gr);
  if (!(share > 0.f)) return;
  g.q = minf(1.f, kUpgRrScale * share);
  if (!(u_rr < g.q)) return;
  g.conn.contrib *= share / (p.n_light * g.q);
  g.active = isfinite3(g.conn.contrib) && !is_black(g.conn.contrib);
}

// One trial of the eye's sampling at `prev`, as vcm_scatter samples it (BSDF
// sample, its validity tests, Russian roulette); false when the trial ends the
// path there (a failed trial). Else `ray` is the trial ray to trace.
CHD bool upg_trial_ray(const VcmParams& p, const VcmPathState& prev, PCG32& rng, Ray& ray) {
  float uc = rng.next_float();
  Vec2f u(rng.next_float(), rng.next_float());
  float u_rr = rng.next_float();
  BSDFSample bs;
  if (!bsdf_sample(prev.m, prev.wo, uc, u, bs, TransportMode::kRadiance)) return false;
  Vec3f wi_world = prev.frame.to_world(bs.wi);
  if (dot(wi_world, prev.sh.ng) * bs.wi.z * dot(prev.sh.ns, prev.sh.ng) < 0.f) return false;
  RGB beta = prev.beta * bs.weight;
  if (is_black(beta) || !isfinite3(beta)) return false;
  if (prev.length >= p.rr_depth) {
    float q = minf(1.f, max_component(beta) / maxf(max_component(prev.beta), 1e-30f));
    if (!(u_rr < q)) return false;
  }
  ray.o = vcm_origin_towards(prev, wi_world);
  ray.d = wi_world;
  ray.tmax = kInf;
  return true;
}

// Whether the trial ray's hit lands within r of the photon (the gather's test).
CHD bool upg_trial_lands(const SceneView& s, const VcmParams& p, const Ray& ray, const Hit& hit, Vec3f photon) {
  if (!hit.valid()) return false;
  SurfaceHit sh = make_surface_hit(s, ray, hit);
  return length_sq(sh.p - photon) < p.radius * p.radius;
}

// The gathering test at an eye hit.
CHD bool upg_in_disc(const VcmParams& p, Vec3f eye, Vec3f photon) {
  return length_sq(eye - photon) < p.radius * p.radius;
}

// The trial random stream of (pass, pixel, eye vertex, photon).
CHD PCG32 upg_trial_rng(const VcmParams& p, uint32_t pixel, uint32_t eye_length, uint32_t photon) {
  return PCG32(hash3(p.seed ^ 0x7570670000000000ull, (uint64_t(p.pass) << 32) | pixel,
                     (uint64_t(eye_length) << 32) | photon),
               mix64(p.seed + 0x9e3779b97f4a7c15ull * (uint64_t(pixel) + 1)));
}

}  // namespace caustica
