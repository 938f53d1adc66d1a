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
// MIS (the paper's combination: gathering as one more strategy in one
// power-heuristic sum over all strategies, as vertex merging in VCM). The gathered
// path x = y_0 .. y_s z_{t-1} .. z_0 is also the path of BDPT's connection (s, t-1)
// of y_s and z_{t-1}; its gathering density, with P approximated for the weights
// as p_eye,A(z_{t-1} -> y_s) pi r^2 (the probability that the eye's sampling
// lands in the disc, to first order), is that connection's times
// N_light pi r^2 p_eye,A(z_{t-1} -> y_s): exactly the density that VCM gives
// the merge of y_s with an eye vertex sampled from z_{t-1}. So the weights are
// VCM's (vcm.h, Georgiev's dVCM/dVC recursion, mode kUpg) with each merge read
// as the gather of the same path, which exists only where the gather can run:
// the photon's neighbour on the camera side must be a non-delta surface
// scattering, never the camera (vcm_after_scatter: vm_here / defer; the t = 1
// weight has no merge term). A gather's weight is then the full weight of the
// connection of its vertex pair times g = mis(N_light pi r^2 p_eye,A(z_{t-1} -> y_s)),
// the gather's term in that sum; the connection keeps its own full weight.
// Every strategy that samples a path computes the same sum, so the weights sum
// to one (tests/cpp/test_vcm_mis.cpp) and the combination is unbiased (up to
// the cap); which approximation of P the weights use affects only the variance.
//
// Cost control: the trials of a low-weighted gather are skipped by Russian
// roulette, survival q = min(1, kUpgRrScale * w_gather), dividing by q
// (unbiased). The expected trial count of a kept photon is 1/P.
//
// Participating media. The paper gathers at surfaces; here too: a gather runs at an eye hit z_t on a surface
// (not at a scattering event in a medium) from a previous eye vertex z_{t-1} that is a non-delta surface
// vertex, and takes the light vertices on surfaces only. The segment between them may cross media and null
// surfaces. Then the eye's sampling from z_{t-1} lands within r of y_s when its direction (BSDF sample and
// roulette, as without media) leads there *and* its free-flight sampling passes every medium on the way
// without scattering, crossing null surfaces; P includes that, and so must the trials (upg_trial_reaches):
// each replays the eye's free-flight sampling with its hero channel (vcm_medium_segment's estimator; a hero
// drawn per trial where the eye has none yet, as its continuation would draw one), so E[N] = 1/P still. The
// connection carries the segment's transmittance (vcm_visibility) like any other, so the contribution is
// f(x) / (p_light p_eye P N_light) as before, f with the exact transmittance of the joining segment. In the
// MIS, a gather exists only where both of its vertices are surfaces: medium vertices have no merge term
// (vcm_medium_vm_rel is 0 for upg), a light vertex's pending term is dropped at a medium vertex after it
// (vcm_upg_medium_vertex), a camera vertex after a medium vertex has none (VcmPathState::vm_ok), and a
// connection to a camera vertex in a medium has no light-side term (vcm_connect_light_vm). The weights'
// densities leave out transmittance, as all of vcm.h's do; they still sum to one (tests/cpp/test_vcm_mis.cpp).
#pragma once
#include "vcm.h"

namespace caustica {

constexpr uint32_t kUpgMaxTrials = 16384;
constexpr float kUpgRrScale = 4.f;

// g = mis(N_light pi r^2 p_eye,A(z -> y)) for camera vertex `cam` (non-delta) and
// light vertex v: the gather's density relative to the connection's.
CHD float upg_gather_ratio(const VcmParams& p, const VcmPathState& cam, const VcmLightVertex& v) {
  Vec3f d = v.sh.p - cam.sh.p;
  float d2 = length_sq(d);
  if (!(d2 > 0.f)) return 0.f;
  Vec3f w = d / std::sqrt(d2);
  float cos_l = absdot(v.sh.ns, w);
  float pdf_a = bsdf_pdf(cam.m, cam.wo, cam.frame.to_local(w)) * cos_l / d2;
  return p.vm_factor * vcm_mis(p, pdf_a);
}

// One gathered photon v at the eye hit after `prev` (z_{t-1}, non-delta): the
// connection's contribution with the gather's MIS weight and 1 / N_light, its
// shadow ray, and the roulette probability of running the trials. The caller
// traces the shadow ray, then multiplies by the trial count N / q.
struct UpgGather {
  VcmShadow conn;   // contrib: f / (p_light p_eye) w_gather / (N_light q)
  float q = 0.f;    // probability of running the trials (Russian roulette)
  bool active = false;
};

CHD void upg_gather(const SceneView& s, const VcmParams& p, const VcmPathState& prev, const VcmLightVertex& v,
                    float u_rr, UpgGather& g) {
  g.active = false;
  vcm_camera_connect(s, p, prev, v, g.conn);  // weight: the connection's full weight w_c
  if (!g.conn.active) return;
  float gr = upg_gather_ratio(p, prev, v);
  float w_gather = g.conn.weight * gr;
  if (!(w_gather > 0.f)) return;
  g.q = minf(1.f, kUpgRrScale * w_gather);
  if (!(u_rr < g.q)) return;
  g.conn.contrib *= gr / (p.n_light * g.q);
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
    float q = minf(1.f, max_abs_component(beta) * vcm_rr_eta2(bs, TransportMode::kRadiance) /
                            maxf(max_abs_component(prev.beta), 1e-30f));
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

// One trial's landing test (header comment, participating media): the eye's continuation from `prev` along
// `ray` reaches a surface within r of the photon. In scenes with media it samples a free-flight distance on
// each segment in a medium as vcm_medium_segment does (prev's hero channel, or one drawn now) and fails where
// that scatters; null surfaces are crossed. `rays` counts the intersections.
template <class Tracer>
CHD bool upg_trial_reaches(const SceneView& s, const VcmParams& p, const VcmPathState& prev, Ray ray, Vec3f photon,
                           PCG32& rng, const Tracer& tracer, uint32_t& rays) {
  Hit hit;
  ++rays;
  tracer.intersect(ray, hit);
  if (!scene_has_media(s)) return upg_trial_lands(s, p, ray, hit, photon);
  int32_t medium = vcm_medium_towards(s, prev, ray.d);
  int32_t hero = prev.hero;
  uint32_t null_crossings = 0;
  for (;;) {
    if (medium >= 0) {
      const Medium& md = s.media[medium];
      const float dlen = length(ray.d);
      const uint64_t track_seed = md.grid >= 0 ? (uint64_t(rng.next_u32()) << 32 | rng.next_u32()) : 0;
      const float u_hero = rng.next_float(), u_dist = rng.next_float();
      if (hero < 0) hero = medium_hero_channel(u_hero);
      const MediumSample ms =
          medium_sample(s, md, ray.o, ray.d / dlen, hit.valid() ? hit.t * dlen : kInf, hero, u_dist, track_seed);
      if (ms.scattered) return false;
    }
    if (!hit.valid()) return false;
    SurfaceHit sh = make_surface_hit(s, ray, hit);
    if (!is_null_surface(s, sh)) return length_sq(sh.p - photon) < p.radius * p.radius;
    if (!cross_null_surface(s, sh, ray, medium, null_crossings)) return false;
    hit = Hit();
    ++rays;
    tracer.intersect(ray, hit);
  }
}

// Estimates of 1/P, P = P(the eye's sampling at `prev` lands within r of `photon`),
// by trials; lands(ray) casts a trial ray and applies the landing test. Both
// return 0 when the trials reach kUpgMaxTrials; `trials` counts the rays cast.
//
// Plain trials (as the paper): repeat the eye's own sampling until one lands;
// the count N is geometric with success probability P, E[N] = 1/P.
template <typename Lands>
CHD float upg_inv_p_plain(const VcmParams& p, const VcmPathState& prev, PCG32& rng, uint32_t& trials,
                          Lands&& lands) {
  for (uint32_t n = 1; n <= kUpgMaxTrials; ++n) {
    Ray ray;
    if (!upg_trial_ray(p, prev, rng, ray)) continue;
    ++trials;
    if (lands(ray)) return float(n);
  }
  return 0.f;
}

// An upper bound M of the BSDF's sampling density (per solid angle) for the
// materials whose sampled direction alone fixes the density and the weight (no
// delta lobe, no lobe-dependent weight); 0 for the others (plain trials only).
CHD float upg_pdf_bound(const Material& m) {
  if (m.type == MaterialType::kDiffuse) return kInvPi;
  if (m.type == MaterialType::kPhong) {
    float pd = phong_diffuse_prob(m);
    return pd * kInvPi + (1.f - pd) * (m.exponent + 1.f) * kInv2Pi;
  }
  return 0.f;
}

// The cone around `photon` as seen from prev's front-side ray origin: any ray that lands
// within r of the photon passes through the ball of radius r, so its direction is
// in this cone of half-angle asin(r / d). Fills the axis frame, 1 - cos(theta_max),
// and Omega M (solid angle times the pdf bound); false if the origin is inside the ball.
struct UpgCone {
  Frame axis;
  float one_minus_cos = 0.f;
  float M = 0.f;
  float omega_m = 0.f;
};
CHD bool upg_cone(const VcmParams& p, const VcmPathState& prev, Vec3f photon, float M, UpgCone& c) {
  Vec3f d = photon - prev.p_front;
  float d2 = length_sq(d);
  float r2 = p.radius * p.radius;
  if (!(M > 0.f) || !(d2 > 1.0001f * r2)) return false;
  float sin2 = r2 / d2;
  float cos_max = std::sqrt(1.f - sin2);
  c.axis = Frame(d / std::sqrt(d2));
  c.one_minus_cos = sin2 / (1.f + cos_max);  // without cancellation for small cones
  c.M = M;
  c.omega_m = 2.f * kPi * c.one_minus_cos * M;
  return true;
}

// Cone trials (the paper's idea of sampling only towards the disc, made exact by
// rejection): a trial draws a direction w uniformly in the cone and accepts it
// with probability p_bsdf(w) v(w) q(w) / M, where v is the eye's validity test and
// q its Russian-roulette survival for w (what upg_trial_ray would apply), then
// casts it. Its success probability is (1 / Omega) Int_cone p v q land / M dw =
// P / (Omega M) (no landing direction lies outside the cone), so the count N is
// geometric and N / (Omega M) estimates 1/P without bias. Expected trials: Omega M / P,
// about (cone / disc solid angle) x (M / p), against 1/P for plain trials: use it when
// Omega M < 1.
template <typename Lands>
CHD float upg_inv_p_cone(const VcmParams& p, const VcmPathState& prev, const UpgCone& c, PCG32& rng, uint32_t& trials,
                         Lands&& lands) {
  const float mb = maxf(max_abs_component(prev.beta), 1e-30f);
  for (uint32_t n = 1; n <= kUpgMaxTrials; ++n) {
    float omc = rng.next_float() * c.one_minus_cos;
    float phi = 2.f * kPi * rng.next_float();
    float u_acc = rng.next_float();
    float sin_t = std::sqrt(maxf(0.f, omc * (2.f - omc)));
    Vec3f w = c.axis.to_world(Vec3f(sin_t * std::cos(phi), sin_t * std::sin(phi), 1.f - omc));
    Vec3f wl = prev.frame.to_local(w);
    if (dot(w, prev.sh.ng) * wl.z * dot(prev.sh.ns, prev.sh.ng) < 0.f) continue;  // validity, as the eye's
    float pdf = bsdf_pdf(prev.m, prev.wo, wl);
    if (!(pdf > 0.f)) continue;
    float acc = pdf;
    if (prev.length >= p.rr_depth) {
      RGB beta = prev.beta * bsdf_eval(prev.m, prev.wo, wl) * (std::fabs(wl.z) / pdf);
      acc *= minf(1.f, max_abs_component(beta) / mb);
    }
    if (!(u_acc * c.M < acc)) continue;  // accept with probability acc / M
    Ray ray;
    ray.o = vcm_origin_towards(prev, w);
    ray.d = w;
    ray.tmax = kInf;
    ++trials;
    if (lands(ray)) return float(n) / c.omega_m;
  }
  return 0.f;
}

// 1/P for a gathered photon: cone trials where they are cheaper (a pdf bound and
// Omega M < 1), else plain trials.
template <typename Lands>
CHD float upg_inv_p(const VcmParams& p, const VcmPathState& prev, Vec3f photon, PCG32& rng, uint32_t& trials,
                    Lands&& lands) {
  UpgCone cone;
  if (upg_cone(p, prev, photon, upg_pdf_bound(prev.m), cone) && cone.omega_m < 1.f)
    return upg_inv_p_cone(p, prev, cone, rng, trials, lands);
  return upg_inv_p_plain(p, prev, rng, trials, lands);
}

// The gathering test at an eye hit.
CHD bool upg_in_disc(const VcmParams& p, Vec3f eye, Vec3f photon) {
  return length_sq(eye - photon) < p.radius * p.radius;
}

// The hash grid holds quantized positions: a gather queries radius r plus this slack (above the quantization
// error of a grid over `bounds`) and makes the exact test upg_in_disc on full-precision positions.
CHD float upg_query_slack(const Bounds3& bounds, float r) {
  Vec3f ext = bounds.hi - bounds.lo;
  float e = ext.x > ext.y ? ext.x : ext.y;
  e = e > ext.z ? e : ext.z;
  float a = 0.05f * r, b = 2.f * e / 65535.f;
  return a > b ? a : b;
}

// The trial random stream of (pass, pixel, eye vertex, photon).
CHD PCG32 upg_trial_rng(const VcmParams& p, uint32_t pixel, uint32_t eye_length, uint32_t photon) {
  return PCG32(hash3(p.seed ^ 0x7570670000000000ull, (uint64_t(p.pass) << 32) | pixel,
                     (uint64_t(eye_length) << 32) | photon),
               mix64(p.seed + 0x9e3779b97f4a7c15ull * (uint64_t(pixel) + 1)));
}

struct UpgGatherCounts {
  uint32_t rays = 0;    // connection visibility rays
  uint32_t trials = 0;  // trial rays for 1/P
  uint32_t capped = 0;  // gathers whose trials reached the cap
};

// Whether the gather runs at the eye hit that vcm_camera_hit just processed: a surface vertex (not a null
// surface crossed, not a scattering event in a medium before the surface) reached from the previous eye vertex
// `prev` (have_prev, kept by upg_track_prev), one segment after it. The length test also refuses a path that a
// medium ended on the way (its throughput black: vcm_camera_hit then leaves st.sh at the previous vertex).
CHD bool upg_gathers_at(const VcmPathState& st, const Hit& hit, bool have_prev, const VcmPathState& prev) {
  return have_prev && hit.valid() && !st.crossing && !st.in_medium && st.length == prev.length + 1;
}

// After the stages at an eye hit: the next gather's previous vertex is this one where it is a non-delta
// surface vertex; a null surface crossed keeps the one before (the eye's segment goes on), any other vertex
// (delta, or a scattering event in a medium) leaves none.
CHD void upg_track_prev(const VcmPathState& st, bool& have_prev, VcmPathState& prev) {
  if (st.crossing) return;
  have_prev = st.vertex_valid && !st.in_medium;
  if (have_prev) prev = st;
}

// The gather at eye hit `st` (z_t) from the previous non-delta eye vertex `prev` (z_{t-1}): every light
// vertex on a surface of `grid` (queried with radius `query_r`, reporting indices into `verts`) inside the
// disc, connected to prev (with the transmittance of the segment in scenes with media) with its trial
// estimate of 1/P, added to st.L in the grid's order. `tracer` answers intersect(Ray, Hit&) and occluded(Ray).
// Shared by the CPU driver and the wavefront.
template <class Tracer>
CHD UpgGatherCounts upg_gather_all(const SceneView& s, const VcmParams& p, const VcmPathState& prev,
                                   VcmPathState& st, const PhotonGridView& grid, float query_r,
                                   const VcmLightVertex* verts, uint32_t pixel, const Tracer& tracer) {
  UpgGatherCounts c;
  if (grid.num_photons == 0) return c;
  grid.query_indexed(st.sh.p, query_r, [&](uint32_t id, const Photon&) {
    const VcmLightVertex& v = verts[id];
    if (v.in_medium() || !upg_in_disc(p, st.sh.p, v.sh.p)) return;
    PCG32 rng = upg_trial_rng(p, pixel, prev.length, id);
    UpgGather g;
    upg_gather(s, p, prev, v, rng.next_float(), g);
    if (!g.active) return;
    ++c.rays;
    const RGB tr = vcm_visibility(s, tracer, g.conn.ray, g.conn.medium);
    if (is_black(tr)) return;
    uint32_t cast = 0, trial_rays = 0;
    float inv_p = upg_inv_p(p, prev, v.sh.p, rng, cast, [&](const Ray& ray) {
      return upg_trial_reaches(s, p, prev, ray, v.sh.p, rng, tracer, trial_rays);
    });
    c.trials += trial_rays;
    if (!(inv_p > 0.f)) {
      ++c.capped;
      return;
    }
    st.L += g.conn.contrib * tr * inv_p;
  });
  return c;
}

}  // namespace caustica
