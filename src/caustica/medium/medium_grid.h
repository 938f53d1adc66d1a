// Heterogeneous participating media: a medium whose coefficients are a density grid times constant
// per-unit-density coefficients, sigma_a(x) = d(x) sigma_a and sigma_s(x) = d(x) sigma_s (the form of
// Mitsuba 3's `heterogeneous` medium with a one-channel sigma_t grid, and of pbrt-v4's `uniformgrid`).
//
// The grid (MediumGrid): nx x ny x nz samples filling the unit cube of grid space, sample (i, j, k) at the
// centre of its cell, ((i + 0.5) / nx, (j + 0.5) / ny, (k + 0.5) / nz), interpolated trilinearly (or taken
// from the nearest sample), the samples clamped at the border (the convention of Mitsuba 3's gridvolume,
// checked against it: a 4-sample row reads 0, 0.5, 1.5, 3 at x = 0.125, 0.25, 0.5, 1). Outside the cube the
// density is 0 (pbrt-v4) or, with `clamp`, the nearest border sample's (Mitsuba 3's default wrap mode). An
// affine map takes world space to grid space, so a grid can be placed, scaled and turned.
//
// Free-flight sampling by delta tracking with null collisions (Woodcock et al. 1965; the null-scattering
// formulation of Miller, Georgiev & Jarosz 2019, "A Null-Scattering Path Integral Formulation of Light
// Transport", as pbrt-v4 uses it in Sec. 14.1.2 and its VolPathIntegrator, Sec. 14.2.2): the majorant
// sigma_maj = d_max (sigma_a + sigma_s) per channel bounds sigma_t(x) along every ray. Tentative collisions
// are drawn at the rate of the path's hero channel's majorant (medium/medium.h); at each, a real collision
// happens with probability sigma_t(x) / sigma_maj = d(x) / d_max (the same in every channel with
// sigma_t > 0), else a null collision and the walk goes on. In the terms of medium/medium.h each tentative
// step of length dt contributes, per channel,
//   null collision:      f = T_maj(dt) sigma_n(x),  p = T_maj(dt) sigma_n(x),  sigma_n = sigma_maj - sigma_t(x)
//   real collision:      f = T_maj(dt) sigma_s(x),  p = T_maj(dt) sigma_t(x)   (a scattering event)
//   reaching the surface: f = p = T_maj(dt)
// with T_maj(dt) = exp(-sigma_maj dt), and the event's f and p are the products over its steps, so the
// path's throughput stays f / avg(r p) over all its medium events and channels (one-sample MIS over the
// channels, pbrt-v4's r_u ratios) and the estimate is unbiased in every channel. For a homogeneous medium
// (d = d_max everywhere) there are no null collisions and this is the free-flight sampling of medium.h.
// The steps' f and p are rescaled together as the walk goes on (they would underflow over many steps);
// their ratios are all that medium_update_throughput uses.
//
// Transmittance of shadow rays by ratio tracking (Novak, Selle & Jarosz 2014, "Residual Ratio Tracking for
// Estimating Attenuation in Participating Media"; pbrt-v4 Sec. 11.2): tentative collisions at one rate mu =
// d_max max_c sigma_t[c] for all channels, and T_c = prod over them of (1 - sigma_t[c](x_i) / mu), an
// unbiased estimate in [0, 1] of each channel's exp(-int sigma_t[c]); Russian roulette once its largest
// channel falls below 0.1 (continue with that probability, divide by it).
//
// Both walks visit only the ray's overlap with the grid's cube when the density outside it is 0. They stop
// after kMaxGridSteps tentative collisions and count the path as absorbed (f = 0, T = 0): a guard for rays
// that never leave a clamped grid, far beyond any real scene's optical depth.
#pragma once
#include <cstdint>
#include "../base/host_device.h"
#include "../base/math.h"
#include "../base/rng.h"
#include "medium.h"

namespace caustica {

constexpr uint32_t kMaxGridSteps = 1u << 20;

struct MediumGrid {
  uint32_t nx = 0, ny = 0, nz = 0;
  uint32_t offset = 0;     // the first sample in SceneView::grid_values; samples x fastest, then y, then z
  Affine world_to_grid;    // world space to grid space (the grid fills [0, 1]^3 there)
  float max_density = 0.f; // d_max: the largest sample (the majorant's density)
  uint32_t nearest = 0;    // 1: the nearest sample; 0: trilinear interpolation
  uint32_t clamp = 0;      // outside the cube: 1 the nearest border sample, 0 density 0
};

CHD float grid_sample_at(const MediumGrid& g, const float* values, int x, int y, int z) {
  x = x < 0 ? 0 : (x >= int(g.nx) ? int(g.nx) - 1 : x);
  y = y < 0 ? 0 : (y >= int(g.ny) ? int(g.ny) - 1 : y);
  z = z < 0 ? 0 : (z >= int(g.nz) ? int(g.nz) - 1 : z);
  return values[g.offset + (size_t(z) * g.ny + size_t(y)) * g.nx + size_t(x)];
}

// The density at grid-space point q (the header comment's convention).
CHD float grid_density_local(const MediumGrid& g, const float* values, Vec3f q) {
  if (!g.clamp && !(q.x >= 0.f && q.x <= 1.f && q.y >= 0.f && q.y <= 1.f && q.z >= 0.f && q.z <= 1.f)) return 0.f;
  // Continuous sample coordinates: sample i sits at i.
  const float fx = q.x * float(g.nx) - 0.5f, fy = q.y * float(g.ny) - 0.5f, fz = q.z * float(g.nz) - 0.5f;
  // Far outside a clamped grid the coordinates could overflow an int; the border sample is the answer there.
  const float lim = 1e7f;
  const float cx = clampf(fx, -lim, lim), cy = clampf(fy, -lim, lim), cz = clampf(fz, -lim, lim);
  if (g.nearest)
    return grid_sample_at(g, values, int(std::floor(cx + 0.5f)), int(std::floor(cy + 0.5f)), int(std::floor(cz + 0.5f)));
  const float x0 = std::floor(cx), y0 = std::floor(cy), z0 = std::floor(cz);
  const int ix = int(x0), iy = int(y0), iz = int(z0);
  const float dx = cx - x0, dy = cy - y0, dz = cz - z0;
  auto v = [&](int a, int b, int c) { return grid_sample_at(g, values, ix + a, iy + b, iz + c); };
  const float c00 = lerpf(dx, v(0, 0, 0), v(1, 0, 0)), c10 = lerpf(dx, v(0, 1, 0), v(1, 1, 0));
  const float c01 = lerpf(dx, v(0, 0, 1), v(1, 0, 1)), c11 = lerpf(dx, v(0, 1, 1), v(1, 1, 1));
  return lerpf(dz, lerpf(dy, c00, c10), lerpf(dy, c01, c11));
}

// The density at world-space point p.
CHD float grid_density(const MediumGrid& g, const float* values, Vec3f p) {
  return grid_density_local(g, values, g.world_to_grid.point(p));
}

// The part [t0, t1] of the ray o + t d, 0 <= t < t_max, where the density can be non-zero: all of it for a
// clamped grid, else its overlap with the grid's cube (the slab test in grid space, where the affine map
// keeps t). False when there is none.
CHD bool grid_ray_overlap(const MediumGrid& g, Vec3f o, Vec3f d, float t_max, float& t0, float& t1) {
  t0 = 0.f;
  t1 = t_max;
  if (g.clamp) return true;
  const Vec3f og = g.world_to_grid.point(o), dg = g.world_to_grid.vector(d);
  for (int a = 0; a < 3; ++a) {
    const float oa = og[a], da = dg[a];
    if (da == 0.f) {
      if (!(oa >= 0.f && oa <= 1.f)) return false;
      continue;
    }
    float ta = (0.f - oa) / da, tb = (1.f - oa) / da;
    if (ta > tb) { const float x = ta; ta = tb; tb = x; }
    t0 = maxf(t0, ta);
    t1 = minf(t1, tb);
  }
  return t0 < t1;
}

// Delta tracking along o + t d (unit d) up to the surface at t_surface (infinity: none), tentative collisions
// drawn in channel `hero`, every random number from rng. See the header comment.
template <typename Rng>
CHD MediumSample grid_sample_distance(const Medium& m, const MediumGrid& g, const float* values, Vec3f o, Vec3f d,
                                      float t_surface, int hero, Rng& rng) {
  MediumSample ms;
  ms.f = ms.p = RGB(1.f);
  float t0, t1;
  if (!grid_ray_overlap(g, o, d, t_surface, t0, t1)) return ms;
  const RGB sigma_t = medium_sigma_t(m), maj = sigma_t * g.max_density;
  const float rate = maj[hero];
  float t = t0;
  for (uint32_t step = 0; step < kMaxGridSteps; ++step) {
    const float dt = rate > 0.f ? -std::log1p(-minf(rng.next_float(), kOneMinusEpsilon)) / rate : kInf;
    if (!(t + dt < t1)) {
      const RGB T = medium_transmittance(maj, t1 - t);
      ms.f *= T;
      ms.p *= T;
      return ms;
    }
    t += dt;
    const RGB T = medium_transmittance(maj, dt);
    const float density = grid_density(g, values, o + d * t);
    const float real = clampf(density / g.max_density, 0.f, 1.f);
    if (rng.next_float() < real) {
      ms.scattered = true;
      ms.t = t;
      ms.sigma_s = m.sigma_s * density;
      ms.Tf = ms.f * T;
      ms.f = ms.Tf * ms.sigma_s;
      ms.p = ms.p * T * (sigma_t * density);
      return ms;
    }
    const RGB sigma_n = maj * (1.f - real);
    ms.f *= T * sigma_n;
    ms.p *= T * sigma_n;
    const float a = (ms.p.x + ms.p.y + ms.p.z) * (1.f / 3.f);
    if (!(a > 0.f)) break;
    ms.f /= a;
    ms.p /= a;
  }
  // Absorbed (the guard in the header comment, or no density left in any channel).
  ms.scattered = false;
  ms.f = RGB(0.f);
  ms.p = RGB(1.f);
  return ms;
}

// Ratio tracking of the transmittance along o + t d (unit d), 0 <= t < t_end. See the header comment.
template <typename Rng>
CHD RGB grid_transmittance(const Medium& m, const MediumGrid& g, const float* values, Vec3f o, Vec3f d, float t_end,
                           Rng& rng) {
  float t0, t1;
  if (!grid_ray_overlap(g, o, d, t_end, t0, t1)) return RGB(1.f);
  const RGB sigma_t = medium_sigma_t(m);
  const float mu = max_component(sigma_t) * g.max_density;
  if (!(mu > 0.f)) return RGB(1.f);
  RGB Tr(1.f);
  float t = t0;
  for (uint32_t step = 0; step < kMaxGridSteps; ++step) {
    t += -std::log1p(-minf(rng.next_float(), kOneMinusEpsilon)) / mu;
    if (!(t < t1)) return Tr;
    const float density = grid_density(g, values, o + d * t);
    Tr *= RGB(1.f) - sigma_t * (density / mu);
    Tr = RGB(maxf(Tr.x, 0.f), maxf(Tr.y, 0.f), maxf(Tr.z, 0.f));
    const float mx = max_component(Tr);
    if (mx < 0.1f) {
      if (!(rng.next_float() < mx)) return RGB(0.f);
      Tr /= mx;
    }
  }
  return RGB(0.f);
}

}  // namespace caustica
