// Heterogeneous participating media: a medium whose coefficients are a density grid times constant
// per-unit-density coefficients, sigma_a(x) = d(x) sigma_a and sigma_s(x) = d(x) sigma_s (the form of
// Mitsuba 3's `heterogeneous` medium with a one-channel sigma_t grid, and of pbrt-v4's `uniformgrid`).
// A colour grid (three channels, Mitsuba 3's RGB sigma_t gridvolume) holds one density per channel, d_c(x),
// and sigma_t,c(x) = d_c(x) sigma_t,c; an albedo grid (one or three channels in [0, 1], Mitsuba 3's albedo
// gridvolume) replaces the constant albedo: sigma_s(x) = albedo(x) sigma_t(x) (Medium::albedo_grid).
//
// The grid (MediumGrid): nx x ny x nz samples filling the unit cube of grid space, sample (i, j, k) at the
// centre of its cell, ((i + 0.5) / nx, (j + 0.5) / ny, (k + 0.5) / nz), interpolated trilinearly (or taken
// from the nearest sample), the samples clamped at the border (the convention of Mitsuba 3's gridvolume,
// checked against it: a 4-sample row reads 0, 0.5, 1.5, 3 at x = 0.125, 0.25, 0.5, 1). Outside the cube the
// density is 0 (pbrt-v4) or, with `clamp`, the nearest border sample's (Mitsuba 3's default wrap mode). An
// affine map takes world space to grid space, so a grid can be placed, scaled and turned.
//
// Majorants: a coarse grid of at most 16^3 cells over the cube (pbrt-v4's majorant grid), each holding the
// largest sample a lookup inside it can read, d_maj (of any channel, in a colour grid); a ray walks the
// cells it crosses (a 3D DDA, Amanatides & Woo 1987, "A Fast Voxel Traversal Algorithm for Ray Tracing"), so
// empty and thin regions cost few or no tentative collisions. With `clamp`, the ray's parts outside the cube
// take d_max, the largest sample.
//
// Free-flight sampling by delta tracking with null collisions (Woodcock et al. 1965; the null-scattering
// formulation of Miller, Georgiev & Jarosz 2019, "A Null-Scattering Path Integral Formulation of Light
// Transport", as pbrt-v4 uses it in Sec. 14.1.2 and its VolPathIntegrator, Sec. 14.2.2): in each cell the
// majorant sigma_maj = d_maj (sigma_a + sigma_s) per channel bounds sigma_t(x). Tentative collisions
// are drawn at the rate of the path's hero channel's majorant (medium/medium.h); at each, a real collision
// happens with probability sigma_t,h(x) / sigma_maj,h = d_h(x) / d_maj in the hero channel h (the same in
// every channel with sigma_t > 0 unless the grid has colour), else a null collision and the walk goes on.
// In the terms of medium/medium.h each tentative step of length dt contributes, per channel,
//   null collision:      f = T_maj(dt) sigma_n(x),  p = T_maj(dt) sigma_n(x),  sigma_n = sigma_maj - sigma_t(x)
//                        (p_c: channel c's rate sigma_maj,c times its null probability sigma_n,c / sigma_maj,c)
//   real collision:      f = T_maj(dt) sigma_s(x),  p = T_maj(dt) sigma_t(x)   (a scattering event)
//   reaching the surface: f = p = T_maj(dt)
// with T_maj(dt) = exp(-sigma_maj dt), and the event's f and p are the products over its steps, so the
// path's throughput stays f / avg(r p) over all its medium events and channels (one-sample MIS over the
// channels, pbrt-v4's r_u ratios) and the estimate is unbiased in every channel. For a homogeneous medium
// (d = d_maj everywhere) there are no null collisions and this is the free-flight sampling of medium.h.
// Crossing a cell's far face without a collision is a step too, of factor and density T_maj of the rest of
// the cell (a fresh exponential sample starts in the next cell: the exponential is memoryless). The steps' f
// and p are rescaled together as the walk goes on (they would underflow over many steps); their ratios are
// all that medium_update_throughput uses.
//
// Transmittance of shadow rays by ratio tracking (Novak, Selle & Jarosz 2014, "Residual Ratio Tracking for
// Estimating Attenuation in Participating Media"; pbrt-v4 Sec. 11.2): tentative collisions at one rate mu =
// d_maj max_c sigma_t[c] for all channels (per cell), and T_c = prod over them of (1 - sigma_t,c(x_i) / mu), an
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
  uint32_t channels = 1;   // 1, or 3 (a colour grid: r, g, b per sample)
  uint32_t offset = 0;     // the first sample in SceneView::grid_values; x fastest, then y, then z, channels innermost
  Affine world_to_grid;    // world space to grid space (the grid fills [0, 1]^3 there)
  float max_density = 0.f; // d_max: the largest sample of any channel (the majorant's density)
  uint32_t nearest = 0;    // 1: the nearest sample; 0: trilinear interpolation
  uint32_t clamp = 0;      // outside the cube: 1 the nearest border sample, 0 density 0
  // The majorant grid (header comment): mx x my x mz cells over the cube, each the largest density in it
  // (of any channel), stored in SceneView::grid_values from maj_offset (x fastest).
  uint32_t mx = 0, my = 0, mz = 0;
  uint32_t maj_offset = 0;
};

// The coarse grid's resolution along an axis of n samples (pbrt-v4 uses 16^3).
constexpr uint32_t kMajorantRes = 16;
CHD uint32_t majorant_res(uint32_t n) { return n < kMajorantRes ? n : kMajorantRes; }

// Sample (x, y, z)'s channel ch, the indices clamped to the grid.
CHD float grid_sample_at(const MediumGrid& g, const float* values, int x, int y, int z, uint32_t ch = 0) {
  x = x < 0 ? 0 : (x >= int(g.nx) ? int(g.nx) - 1 : x);
  y = y < 0 ? 0 : (y >= int(g.ny) ? int(g.ny) - 1 : y);
  z = z < 0 ? 0 : (z >= int(g.nz) ? int(g.nz) - 1 : z);
  return values[g.offset + ((size_t(z) * g.ny + size_t(y)) * g.nx + size_t(x)) * g.channels + ch];
}

// Channel ch trilinearly between samples (ix, iy, iz) and (ix + 1, iy + 1, iz + 1) at fractions (dx, dy, dz).
CHD float grid_trilinear(const MediumGrid& g, const float* values, int ix, int iy, int iz, float dx, float dy,
                         float dz, uint32_t ch) {
  auto v = [&](int a, int b, int c) { return grid_sample_at(g, values, ix + a, iy + b, iz + c, ch); };
  const float c00 = lerpf(dx, v(0, 0, 0), v(1, 0, 0)), c10 = lerpf(dx, v(0, 1, 0), v(1, 1, 0));
  const float c01 = lerpf(dx, v(0, 0, 1), v(1, 0, 1)), c11 = lerpf(dx, v(0, 1, 1), v(1, 1, 1));
  return lerpf(dz, lerpf(dy, c00, c10), lerpf(dy, c01, c11));
}

// The grid's value at grid-space point q (the header comment's convention): a colour grid's three channels,
// a one-channel grid's value in all three.
CHD RGB grid_value_local(const MediumGrid& g, const float* values, Vec3f q) {
  if (!g.clamp && !(q.x >= 0.f && q.x <= 1.f && q.y >= 0.f && q.y <= 1.f && q.z >= 0.f && q.z <= 1.f))
    return RGB(0.f);
  // Continuous sample coordinates: sample i sits at i.
  const float fx = q.x * float(g.nx) - 0.5f, fy = q.y * float(g.ny) - 0.5f, fz = q.z * float(g.nz) - 0.5f;
  // Far outside a clamped grid the coordinates could overflow an int; the border sample is the answer there.
  const float lim = 1e7f;
  const float cx = clampf(fx, -lim, lim), cy = clampf(fy, -lim, lim), cz = clampf(fz, -lim, lim);
  if (g.nearest) {
    const int x = int(std::floor(cx + 0.5f)), y = int(std::floor(cy + 0.5f)), z = int(std::floor(cz + 0.5f));
    if (g.channels == 1) return RGB(grid_sample_at(g, values, x, y, z));
    return RGB(grid_sample_at(g, values, x, y, z, 0), grid_sample_at(g, values, x, y, z, 1),
               grid_sample_at(g, values, x, y, z, 2));
  }
  const float x0 = std::floor(cx), y0 = std::floor(cy), z0 = std::floor(cz);
  const int ix = int(x0), iy = int(y0), iz = int(z0);
  const float dx = cx - x0, dy = cy - y0, dz = cz - z0;
  if (g.channels == 1) return RGB(grid_trilinear(g, values, ix, iy, iz, dx, dy, dz, 0));
  return RGB(grid_trilinear(g, values, ix, iy, iz, dx, dy, dz, 0), grid_trilinear(g, values, ix, iy, iz, dx, dy, dz, 1),
             grid_trilinear(g, values, ix, iy, iz, dx, dy, dz, 2));
}

// The grid's value at world-space point p.
CHD RGB grid_value(const MediumGrid& g, const float* values, Vec3f p) {
  return grid_value_local(g, values, g.world_to_grid.point(p));
}

// The coefficients of grid medium m (m.grid >= 0) at world-space point p: sigma_t(p) = d(p) (sigma_a +
// sigma_s), and sigma_s(p) = d(p) sigma_s or, with an albedo grid, albedo(p) sigma_t(p). `grids` is the
// scene's grid list (SceneView::medium_grids), which m's indices name.
struct GridCoefficients {
  RGB sigma_t, sigma_s;
};
CHD RGB grid_sigma_s(const Medium& m, const MediumGrid* grids, const float* values, Vec3f p, RGB density,
                     RGB sigma_t_p) {
  return m.albedo_grid >= 0 ? grid_value(grids[m.albedo_grid], values, p) * sigma_t_p : m.sigma_s * density;
}
CHD GridCoefficients grid_coefficients(const Medium& m, const MediumGrid* grids, const float* values, Vec3f p) {
  const RGB density = grid_value(grids[m.grid], values, p);
  GridCoefficients c;
  c.sigma_t = medium_sigma_t(m) * density;
  c.sigma_s = grid_sigma_s(m, grids, values, p, density, c.sigma_t);
  return c;
}

// The part [t0, t1) of the ray og + t dg (in grid space), 0 <= t < t_max, inside the unit cube (the slab
// test); t0 >= t1 when there is none.
CHD void grid_cube_overlap_local(Vec3f og, Vec3f dg, float t_max, float& t0, float& t1) {
  t0 = 0.f;
  t1 = t_max;
  for (int a = 0; a < 3; ++a) {
    const float oa = og[a], da = dg[a];
    if (da == 0.f) {
      if (!(oa >= 0.f && oa <= 1.f)) t1 = -1.f;
      continue;
    }
    float ta = (0.f - oa) / da, tb = (1.f - oa) / da;
    if (ta > tb) { const float x = ta; ta = tb; tb = x; }
    t0 = maxf(t0, ta);
    t1 = minf(t1, tb);
  }
}
// The same for the world-space ray o + t d: the affine map to grid space keeps t.
CHD void grid_cube_overlap(const MediumGrid& g, Vec3f o, Vec3f d, float t_max, float& t0, float& t1) {
  grid_cube_overlap_local(g.world_to_grid.point(o), g.world_to_grid.vector(d), t_max, t0, t1);
}

// The ray's path through the majorant grid, as segments [t0, t1) of constant majorant density d: the cells
// of the cube it crosses in order (a 3D DDA, Amanatides & Woo 1987), and with a clamped grid the parts before
// and after the cube at d_max. Segments cover [0, t_max) where the density can be non-zero.
struct MajorantSegment {
  float t0 = 0.f, t1 = 0.f, d = 0.f;
};
struct MajorantWalk {
  float t_max = 0.f, tin = 0.f, tout = 0.f;  // the ray's range; its overlap with the cube (tin >= tout: none)
  float t = 0.f;                             // where the next segment starts
  int phase = 3;                             // 0 before the cube, 1 in it, 2 after it, 3 done
  int cell[3] = {0, 0, 0}, step[3] = {0, 0, 0};
  float next_t[3] = {0.f, 0.f, 0.f}, delta_t[3] = {0.f, 0.f, 0.f};
};

CHD MajorantWalk majorant_walk(const MediumGrid& g, Vec3f o, Vec3f d, float t_max) {
  MajorantWalk w;
  w.t_max = t_max;
  const Vec3f og = g.world_to_grid.point(o), dg = g.world_to_grid.vector(d);
  float t0, t1;
  grid_cube_overlap_local(og, dg, t_max, t0, t1);
  w.tin = t0;
  w.tout = t1;
  const bool inside = t0 < t1;
  w.phase = g.clamp ? 0 : (inside ? 1 : 3);
  w.t = g.clamp ? 0.f : t0;
  if (inside) {
    const uint32_t m[3] = {g.mx, g.my, g.mz};
    const Vec3f p = og + dg * t0;
    for (int a = 0; a < 3; ++a) {
      const float pa = clampf(p[a], 0.f, 1.f) * float(m[a]);
      int c = int(std::floor(pa));
      c = c < 0 ? 0 : (c >= int(m[a]) ? int(m[a]) - 1 : c);
      w.cell[a] = c;
      if (dg[a] == 0.f) {
        w.step[a] = 0;
        w.next_t[a] = kInf;
        w.delta_t[a] = kInf;
        continue;
      }
      w.step[a] = dg[a] > 0.f ? 1 : -1;
      const float bound = float(c + (dg[a] > 0.f ? 1 : 0)) / float(m[a]);
      w.next_t[a] = t0 + (bound - p[a]) / dg[a];
      w.delta_t[a] = 1.f / (float(m[a]) * std::fabs(dg[a]));
    }
  }
  return w;
}

// The next segment of the walk; false when there is none left.
CHD bool majorant_next(const MediumGrid& g, const float* values, MajorantWalk& w, MajorantSegment& seg) {
  while (w.phase < 3) {
    if (w.phase == 0) {  // a clamped grid before the cube: d_max up to the cube (or the whole ray)
      w.phase = w.tin < w.tout ? 1 : 2;
      const float end = w.tin < w.tout ? w.tin : w.t_max;
      if (end > w.t) {
        seg = {w.t, end, g.max_density};
        w.t = end;
        if (w.phase == 2 && !(w.t < w.t_max)) w.phase = 3;
        return true;
      }
      if (w.phase == 2 && !(w.t < w.t_max)) w.phase = 3;
      continue;
    }
    if (w.phase == 1) {
      int a = 0;
      if (w.next_t[1] < w.next_t[a]) a = 1;
      if (w.next_t[2] < w.next_t[a]) a = 2;
      const float end = minf(w.next_t[a], w.tout);
      seg.t0 = w.t;
      seg.t1 = end;
      seg.d = values[g.maj_offset + (size_t(w.cell[2]) * g.my + size_t(w.cell[1])) * g.mx + size_t(w.cell[0])];
      w.t = end;
      const uint32_t m[3] = {g.mx, g.my, g.mz};
      if (!(end < w.tout)) {
        w.phase = g.clamp ? 2 : 3;
      } else {
        w.cell[a] += w.step[a];
        w.next_t[a] += w.delta_t[a];
        if (w.cell[a] < 0 || w.cell[a] >= int(m[a])) {  // left the cube early by rounding
          w.t = w.tout;
          w.phase = g.clamp ? 2 : 3;
        }
      }
      if (seg.t1 > seg.t0) return true;
      continue;
    }
    // phase 2: a clamped grid after the cube
    w.phase = 3;
    if (w.t_max > w.t) {
      seg = {w.t, w.t_max, g.max_density};
      w.t = w.t_max;
      return true;
    }
  }
  return false;
}

// D(t) = the integral of the majorant density over the walk up to t (0 <= t): exp(-sigma_t D(t)) is the
// majorant's transmittance, a lower bound of T(t) known without random numbers (the path tracer's proxy for
// the free-flight density in its MIS weights against equiangular sampling, integrator/path.h).
CHD float grid_majorant_depth(const MediumGrid& g, const float* values, Vec3f o, Vec3f d, float t) {
  MajorantWalk w = majorant_walk(g, o, d, t);
  MajorantSegment seg;
  float depth = 0.f;
  while (majorant_next(g, values, w, seg))
    if (seg.d > 0.f) depth += seg.d * (seg.t1 - seg.t0);
  return depth;
}

// Delta tracking in grid medium m along o + t d (unit d) up to the surface at t_surface (infinity: none),
// tentative collisions drawn in channel `hero`, every random number from rng. See the header comment.
// `grids`: the scene's grid list (m.grid and m.albedo_grid index it).
template <typename Rng>
CHD MediumSample grid_sample_distance(const Medium& m, const MediumGrid* grids, const float* values, Vec3f o,
                                      Vec3f d, float t_surface, int hero, Rng& rng) {
  const MediumGrid& g = grids[m.grid];
  MediumSample ms;
  ms.f = ms.p = RGB(1.f);
  const RGB sigma_t = medium_sigma_t(m);
  MajorantWalk w = majorant_walk(g, o, d, t_surface);
  MajorantSegment seg;
  uint32_t steps = 0;
  bool absorbed = false;  // the guard in the header comment, or no density left in any channel
  while (!absorbed && majorant_next(g, values, w, seg)) {
    const RGB maj = sigma_t * seg.d;
    const float rate = maj[hero];
    float t = seg.t0;
    for (;;) {
      if (++steps > kMaxGridSteps) {
        absorbed = true;
        break;
      }
      const float dt = rate > 0.f ? -std::log1p(-minf(rng.next_float(), kOneMinusEpsilon)) / rate : kInf;
      if (!(t + dt < seg.t1)) {  // through the segment: its majorant transmittance, to both f and p
        const RGB T = medium_transmittance(maj, seg.t1 - t);
        ms.f *= T;
        ms.p *= T;
        break;
      }
      t += dt;
      const RGB T = medium_transmittance(maj, dt);
      const Vec3f x = o + d * t;
      const RGB density = grid_value(g, values, x);
      const float real = clampf(density[hero] / seg.d, 0.f, 1.f);
      if (rng.next_float() < real) {
        const RGB sigma_t_x = sigma_t * density;
        ms.scattered = true;
        ms.t = t;
        ms.sigma_s = grid_sigma_s(m, grids, values, x, density, sigma_t_x);
        if (medium_emits(m)) {
          const RGB Le = m.emission_grid >= 0 ? m.Le * grid_value(grids[m.emission_grid], values, x) : m.Le;
          ms.sigma_a_Le = max0(sigma_t_x - ms.sigma_s) * Le;
        }
        ms.Tf = ms.f * T;
        ms.f = ms.Tf * ms.sigma_s;
        ms.p = ms.p * T * sigma_t_x;
        return ms;
      }
      // Per channel sigma_maj - sigma_t(x) (its density d_maj - d_c(x), at least 0).
      const RGB sigma_n = sigma_t * max0(RGB(seg.d) - density);
      ms.f *= T * sigma_n;
      ms.p *= T * sigma_n;
    }
    const float a = (ms.p.x + ms.p.y + ms.p.z) * (1.f / 3.f);
    if (!(a > 0.f)) absorbed = true;
    else {
      ms.f /= a;
      ms.p /= a;
    }
  }
  if (absorbed) {
    ms.f = RGB(0.f);
    ms.p = RGB(1.f);
  }
  return ms;  // the surface (or absorbed)
}

// Ratio tracking of grid medium m's transmittance along o + t d (unit d), 0 <= t < t_end. See the header
// comment. `grids`: the scene's grid list.
template <typename Rng>
CHD RGB grid_transmittance(const Medium& m, const MediumGrid* grids, const float* values, Vec3f o, Vec3f d,
                           float t_end, Rng& rng) {
  const MediumGrid& g = grids[m.grid];
  const RGB sigma_t = medium_sigma_t(m);
  const float st_max = max_component(sigma_t);
  RGB Tr(1.f);
  MajorantWalk w = majorant_walk(g, o, d, t_end);
  MajorantSegment seg;
  uint32_t steps = 0;
  while (majorant_next(g, values, w, seg)) {
    const float mu = st_max * seg.d;
    if (!(mu > 0.f)) continue;
    float t = seg.t0;
    for (;;) {
      if (++steps > kMaxGridSteps) return RGB(0.f);
      t += -std::log1p(-minf(rng.next_float(), kOneMinusEpsilon)) / mu;
      if (!(t < seg.t1)) break;
      const RGB density = grid_value(g, values, o + d * t);
      Tr *= RGB(1.f) - sigma_t * density / mu;
      Tr = max0(Tr);
      const float mx = max_component(Tr);
      if (mx < 0.1f) {
        if (!(rng.next_float() < mx)) return RGB(0.f);
        Tr /= mx;
      }
    }
  }
  return Tr;
}

}  // namespace caustica
