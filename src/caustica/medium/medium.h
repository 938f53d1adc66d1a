// Participating media: homogeneous media with a Henyey-Greenstein phase function, for the volumetric path
// tracer (integrator/path.h).
//
// Radiative transfer along a ray x(t) = o + t d (Chandrasekhar 1960; in pbrt-v4's notation, Sec. 11.1 and
// Eq. 14.3): with sigma_t = sigma_a + sigma_s constant in the medium, the transmittance between two points t
// apart is T(t) = exp(-sigma_t t) (Beer-Lambert, pbrt-v4 Eq. 11.12), and the radiance arriving at o is
//   L = T(t_s) L_surface + int_0^t_s T(t) sigma_s int_S2 p(w', -d) L_i(x(t), w') dw' dt.
//
// Distance sampling (free-flight sampling, pbrt-v3 Sec. 15.2.2): sigma_t is RGB, so one channel, the
// path's hero channel h (chosen uniformly once per path), draws every distance with density
// sigma_t[h] exp(-sigma_t[h] t). Each channel's estimate is then divided by the path's distance density
// averaged over the three channels (one-sample MIS with the balance heuristic over the channels, Veach 1997
// Sec. 9.2.4, applied to the whole path as pbrt-v4's VolPathIntegrator does with its r_u ratios, Sec. 14.2):
// unbiased in every channel, and a channel's weight is at most 3 times its own analog estimate however long
// the path (a per-event average would let the weights of a strongly coloured medium multiply up along the
// path into heavy tails). Per event the sampler returns the integrand factor f and the per-channel densities
// p of what it sampled:
//   t < t_s: a scattering event, f = T(t) sigma_s, p = sigma_t T(t);
//   else:    the surface,        f = T(t_s),        p = T(t_s);
// and the path keeps r, the product of the p's scaled to average 1, and its throughput beta as
// f_1 ... f_n / avg(p_1 ... p_n) (medium_update_throughput). A channel with sigma_t = 0 never scatters.
//
// The Henyey-Greenstein phase function (Henyey & Greenstein 1941; pbrt-v4 Eq. 11.16 with its convention
// that wo points back along the ray, so that g > 0 scatters forward):
//   p(cos) = (1 - g^2) / (4 pi (1 + g^2 + 2 g cos)^{3/2}),  cos = dot(wo, wi),
// sampled exactly by inverting its CDF in cos (pbrt-v4 Eq. 11.17 in its form for wo), so the sampling weight
// p / pdf is 1.
//
// Emission (pbrt-v4 Sec. 11.1.2; the emission term of its source function, Sec. 11.1.4): an emissive medium adds
// sigma_a(x) Le(x) per unit length to the radiance along a ray, attenuated by T like everything else, so the
// integral above gains int_0^t_s T(t) sigma_a Le dt. The path tracer estimates it at each scattering event
// (a collision estimator: at the sampled t it adds f / avg(r p) with f = T(t) sigma_a Le and p the event's
// densities, the same weight the event's sigma_s factor gets, so it is unbiased in every channel for the
// reason the scattering is). pbrt-v4's VolPathIntegrator also scores emission at null collisions; here a grid
// medium scores it at real collisions only (more variance in thin emitters, the same expectation).
#pragma once
#include <cstdint>
#include "../base/host_device.h"
#include "../base/math.h"

namespace caustica {

struct Medium {
  RGB sigma_a{0.f};  // absorption coefficient (per unit length; of a grid medium, per unit density)
  RGB sigma_s{0.f};  // scattering coefficient (likewise)
  float g = 0.f;     // Henyey-Greenstein asymmetry in (-1, 1); 0 = isotropic
  // A heterogeneous medium's density grid (index into SceneView::medium_grids, medium/medium_grid.h): the
  // coefficients at x are density(x) times the two above (per channel with a colour grid). -1: homogeneous.
  int32_t grid = -1;
  // With a density grid, an albedo grid (an index like `grid`, its samples in [0, 1]) may replace the constant
  // albedo: sigma_s(x) = albedo(x) sigma_t(x), sigma_t(x) = density(x) (sigma_a + sigma_s). -1: none.
  int32_t albedo_grid = -1;
  // Emitted radiance: the medium adds sigma_a(x) Le(x) per unit length (header comment), Le(x) = Le, or with
  // an emission grid (an index like `grid`, one or three channels >= 0) Le times the grid's value at x.
  RGB Le{0.f};
  int32_t emission_grid = -1;
};

CHD bool medium_emits(const Medium& m) { return m.Le.x > 0.f || m.Le.y > 0.f || m.Le.z > 0.f; }

// Which media lie on either side of a surface: `interior` behind its geometric normal (where a ray goes
// with dot(d, ng) < 0), `exterior` in front; -1 = vacuum. A surface with no interface (both kNoMedium
// and `transition` false) keeps the medium of the ray that crosses it (pbrt-v4's and Mitsuba 3's rule for shapes
// without a MediumInterface).
struct MediumInterface {
  int32_t interior = -1, exterior = -1;
  uint32_t transition = 0;  // 1: crossing this surface enters `interior` or `exterior`
};

CHD RGB medium_sigma_t(const Medium& m) { return m.sigma_a + m.sigma_s; }

// The medium a ray with direction d is in as it leaves (crosses or is reflected by) a surface with
// interface mi and normal ng, coming from `current`: the side's medium at a medium boundary, else `current`.
CHD int32_t medium_after_crossing(const MediumInterface& mi, Vec3f d, Vec3f ng, int32_t current) {
  if (!mi.transition) return current;
  return dot(d, ng) < 0.f ? mi.interior : mi.exterior;
}

// The hero channel of a path (the header comment), drawn from the uniform number u at its first medium event.
CHD int32_t medium_hero_channel(float u) { return u < 1.f / 3.f ? 0 : (u < 2.f / 3.f ? 1 : 2); }

// exp(-sigma_t * t), with t = infinity giving 0 where sigma_t > 0 and 1 where it is 0.
CHD RGB medium_transmittance(RGB sigma_t, float t) {
  RGB r;
  for (int c = 0; c < 3; ++c) r[c] = sigma_t[c] > 0.f ? std::exp(-sigma_t[c] * t) : 1.f;
  return r;
}

struct MediumSample {
  bool scattered = false;
  float t = 0.f;  // scattering distance (when scattered)
  RGB f{0.f};     // T sigma_s (scattered) or T (surface)
  RGB p{0.f};     // per channel, the density of this outcome: sigma_t T (scattered) or T (surface)
  // When scattered: f without the sigma_s factor (f = Tf sigma_s), and sigma_s at the event. For a grid
  // medium (medium/medium_grid.h) f, p and Tf share one arbitrary positive factor (only their ratios enter
  // medium_update_throughput), so p is not an absolute density there.
  RGB Tf{0.f};
  RGB sigma_s{0.f};
  // When scattered in an emissive medium: sigma_a(x) Le(x) at the event (its emission is Tf times this,
  // weighted like the event's sigma_s factor; header comment), else 0.
  RGB sigma_a_Le{0.f};
};

// Free-flight sampling along a ray through `m` whose next surface is t_surface away (infinity: none), the
// distance drawn in channel `hero` from the uniform number u_dist. See the header comment.
CHD MediumSample sample_medium_distance(const Medium& m, float t_surface, int hero, float u_dist) {
  MediumSample ms;
  const RGB st = medium_sigma_t(m);
  float t = st[hero] > 0.f ? -std::log1p(-minf(u_dist, kOneMinusEpsilon)) / st[hero] : kInf;
  if (t < t_surface) {
    RGB T = medium_transmittance(st, t);
    ms.scattered = true;
    ms.t = t;
    ms.f = m.sigma_s * T;
    ms.p = st * T;
    ms.Tf = T;
    ms.sigma_s = m.sigma_s;
    ms.sigma_a_Le = m.sigma_a * m.Le;
    return ms;
  }
  RGB T = medium_transmittance(st, t_surface);
  ms.f = T;
  ms.p = T;
  return ms;
}

// The emission of a scattering event `ms` for a path with throughput beta and density ratios r before the
// event (header comment): beta Tf sigma_a Le / avg(r p); 0 when the medium does not emit.
CHD RGB medium_event_emission(const MediumSample& ms, const RGB& beta, const RGB& r) {
  if (!ms.scattered || is_black(ms.sigma_a_Le)) return RGB(0.f);
  const RGB rp = r * ms.p;
  const float a = (rp.x + rp.y + rp.z) * (1.f / 3.f);
  return a > 0.f ? beta * ms.Tf * ms.sigma_a_Le / a : RGB(0.f);
}

// Folds one medium event into a path's throughput beta and its density ratios r (average 1): beta becomes
// beta f / avg(r p) and r becomes r p / avg(r p). Then beta is always f_1..f_n / avg(p_1..p_n) over the
// path's medium events (times its surface factors), as the header comment asks. Returns false when the
// path has no density left (it cannot continue).
CHD bool medium_update_throughput(const MediumSample& ms, RGB& beta, RGB& r) {
  RGB rp = r * ms.p;
  float a = (rp.x + rp.y + rp.z) * (1.f / 3.f);
  if (!(a > 0.f)) return false;
  beta = beta * ms.f / a;
  r = rp / a;
  return true;
}

// Equiangular sampling of a distance along a ray (Kulla & Fajardo 2012, "Importance Sampling Techniques
// for Path Tracing in Participating Media", Sec. 4.1): for a point c off the unit-direction ray o + t d,
// t in [0, t_max), the density proportional to 1 / |x(t) - c|^2, which cancels the inverse-square falloff
// of a point light at c. With delta = dot(c - o, d) and D the distance from c to the ray's line, t = delta +
// D tan(theta) for theta uniform between theta_a = atan(-delta / D) and theta_b = atan((t_max - delta) / D),
// pdf(t) = D / ((theta_b - theta_a) (D^2 + (t - delta)^2)).
struct EquiangularSegment {
  float delta = 0.f, D = 0.f, theta_a = 0.f, theta_b = 0.f;
  bool valid = false;
};
CHD EquiangularSegment equiangular_segment(Vec3f o, Vec3f d, float t_max, Vec3f c) {
  EquiangularSegment e;
  e.delta = dot(c - o, d);
  e.D = length(c - (o + d * e.delta));
  if (!(e.D > 1e-6f)) return e;  // the light on the ray's line: no density to speak of
  e.theta_a = std::atan2(-e.delta, e.D);
  e.theta_b = std::isfinite(t_max) ? std::atan2(t_max - e.delta, e.D) : 0.5f * kPi;
  e.valid = e.theta_b > e.theta_a;
  return e;
}
CHD float equiangular_sample(const EquiangularSegment& e, float u) {
  return e.delta + e.D * std::tan(lerpf(u, e.theta_a, e.theta_b));
}
CHD float equiangular_pdf(const EquiangularSegment& e, float t) {
  if (!e.valid) return 0.f;
  float x = t - e.delta;
  return e.D / ((e.theta_b - e.theta_a) * (e.D * e.D + x * x));
}

// Henyey-Greenstein, with cos_theta = dot(wo, wi) and wo pointing back along the incoming ray.
CHD float hg_phase(float cos_theta, float g) {
  float denom = 1.f + g * g + 2.f * g * cos_theta;
  return kInv4Pi * (1.f - g * g) / (denom * safe_sqrt(denom));
}

// Samples wi for wo (both unit vectors, wo pointing back along the incoming ray); the density is
// hg_phase(dot(wo, wi), g), returned in *pdf.
CHD Vec3f hg_sample(Vec3f wo, float g, Vec2f u, float* pdf) {
  float cos_theta;
  if (std::fabs(g) < 1e-3f) {
    cos_theta = 1.f - 2.f * u.x;
  } else {
    // Inverse CDF of cos in the convention above (cos = -1 is straight ahead for g > 0).
    float sq = (1.f - g * g) / (1.f + g - 2.f * g * u.x);
    cos_theta = -(1.f + g * g - sq * sq) / (2.f * g);
  }
  cos_theta = clampf(cos_theta, -1.f, 1.f);
  float sin_theta = safe_sqrt(1.f - cos_theta * cos_theta);
  float phi = 2.f * kPi * u.y;
  Frame f(wo);
  Vec3f wi = f.to_world(Vec3f(sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta));
  *pdf = hg_phase(cos_theta, g);
  return wi;
}

}  // namespace caustica
