// Heterogeneous media (medium/medium_grid.h): the grid's lookup convention (Mitsuba 3's gridvolume: cell-
// centred samples, trilinear, clamped border; colour grids channel by channel), its placement by Scene's
// build (the inverse of to_world), the majorant grid's walk (contiguous segments bounding the density),
// delta tracking's collision distances against the exact density sigma_t(t) T(t) (chi-square, chi2.h; with
// a negative control whose majorant is too small), its per-channel unbiasedness with chromatic coefficients
// through a turned, scaled grid, and with a colour grid and an albedo grid (Monte Carlo means against
// quadrature, 4 standard errors), and ratio tracking's transmittance (unbiased per channel, every estimate in
// [0, 1]).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "caustica/base/error.h"
#include "caustica/base/rng.h"
#include "caustica/medium/medium_grid.h"
#include "caustica/scene/scene.h"
#include "chi2.h"
#include "moments.h"

using namespace caustica;

namespace {

// Chi-square tests in this file (the Sidak correction is over these; the negative control is not one).
constexpr int kNumChi2Tests = 2;


// A grid built the way Scene::build builds it (so world_to_grid is the inverse of to_world).
struct BuiltGrid {
  MediumGrid g;
  std::vector<float> values;
};
BuiltGrid build(const MediumGridDesc& gd) {
  SceneDesc d;
  d.grids.push_back(gd);
  BuiltGrid b;
  std::vector<MediumGrid> gs;
  build_medium_grids(d, gs, b.values);
  b.g = gs.at(0);
  return b;
}

MediumGridDesc row(std::vector<float> v) {
  MediumGridDesc gd;
  gd.nx = int(v.size());
  gd.ny = gd.nz = 1;
  gd.values = std::move(v);
  return gd;
}

// int_a^b of sigma(t) along o + t d by the trapezoid rule on n steps (the density is piecewise trilinear:
// its kinks cost O(h^2) each).
template <class F>
double integrate(F&& f, double a, double b, int n = 200000) {
  const double h = (b - a) / n;
  double s = 0.5 * (f(a) + f(b));
  for (int i = 1; i < n; ++i) s += f(a + h * i);
  return s * h;
}

float hero_of(float u) { return u < 1.f / 3.f ? 0 : (u < 2.f / 3.f ? 1 : 2); }

}  // namespace

TEST(MediumGrid, LookupFollowsMitsubasGridvolume) {
  // Mitsuba 3.9.1's gridvolume on the row [0, 1, 2, 3] reads 0, 0, 0.5, 1, 1.5, 2, 3, 3 at x = 0, 0.125,
  // 0.25, 0.375, 0.5, 0.625, 0.875, 1, and 3 at x = 1.1 (its default wrap mode clamps); with
  // filter_type nearest 0 at 0.24, 1 at 0.26, 2 at 0.51 (measured with mitsuba's Python module).
  MediumGridDesc gd = row({0.f, 1.f, 2.f, 3.f});
  gd.clamp = true;
  BuiltGrid b = build(gd);
  const float xs[] = {0.f, 0.125f, 0.25f, 0.375f, 0.5f, 0.625f, 0.875f, 1.f, 1.1f, -0.1f};
  const float want[] = {0.f, 0.f, 0.5f, 1.f, 1.5f, 2.f, 3.f, 3.f, 3.f, 0.f};
  for (int i = 0; i < 10; ++i)
    EXPECT_NEAR(grid_value(b.g, b.values.data(), Vec3f(xs[i], 0.5f, 0.5f)).x, want[i], 1e-6f) << xs[i];
  EXPECT_FLOAT_EQ(b.g.max_density, 3.f);
  // Outside the unit cube without clamp: no medium (pbrt-v4's grid).
  gd.clamp = false;
  b = build(gd);
  EXPECT_EQ(grid_value(b.g, b.values.data(), Vec3f(1.1f, 0.5f, 0.5f)).x, 0.f);
  EXPECT_EQ(grid_value(b.g, b.values.data(), Vec3f(0.5f, -0.01f, 0.5f)).x, 0.f);
  EXPECT_NEAR(grid_value(b.g, b.values.data(), Vec3f(0.5f, 0.5f, 0.5f)).x, 1.5f, 1e-6f);
  gd.nearest = true;
  b = build(gd);
  EXPECT_EQ(grid_value(b.g, b.values.data(), Vec3f(0.24f, 0.5f, 0.5f)).x, 0.f);
  EXPECT_EQ(grid_value(b.g, b.values.data(), Vec3f(0.26f, 0.5f, 0.5f)).x, 1.f);
  EXPECT_EQ(grid_value(b.g, b.values.data(), Vec3f(0.51f, 0.5f, 0.5f)).x, 2.f);
}

TEST(MediumGrid, TrilinearInThreeDimensionsAndPlacedByItsTransform) {
  // A 2x2x2 grid: at a grid-space point between the sample centres (0.25, 0.75 on each axis) the density is
  // the trilinear blend of the eight samples; to_world scales the cube by (2, 4, 1) and moves it by (1, -1, 3).
  MediumGridDesc gd;
  gd.nx = gd.ny = gd.nz = 2;
  gd.values = {1, 2, 3, 4, 5, 6, 7, 8};  // x fastest, then y, then z
  gd.to_world.m[0][0] = 2.f;
  gd.to_world.m[1][1] = 4.f;
  gd.to_world.m[2][2] = 1.f;
  gd.to_world.m[0][3] = 1.f;
  gd.to_world.m[1][3] = -1.f;
  gd.to_world.m[2][3] = 3.f;
  BuiltGrid b = build(gd);
  const Vec3f q(0.4f, 0.6f, 0.3f);  // grid space
  const float fx = q.x * 2 - 0.5f, fy = q.y * 2 - 0.5f, fz = q.z * 2 - 0.5f;
  auto v = [&](int x, int y, int z) { return gd.values[(z * 2 + y) * 2 + x]; };
  float want = 0.f;
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x)
        want += v(x, y, z) * (x ? fx : 1 - fx) * (y ? fy : 1 - fy) * (z ? fz : 1 - fz);
  const Vec3f world(1.f + 2.f * q.x, -1.f + 4.f * q.y, 3.f + q.z);
  EXPECT_NEAR(grid_value(b.g, b.values.data(), world).x, want, 1e-5f);
  // The majorant walk along +x through the placed cube's middle from x = 0 covers its overlap, [1, 3].
  MajorantWalk w = majorant_walk(b.g, Vec3f(0.f, 1.f, 3.5f), Vec3f(1.f, 0.f, 0.f), kInf);
  MajorantSegment seg;
  float first = -1.f, last = -1.f;
  while (majorant_next(b.g, b.values.data(), w, seg)) {
    if (first < 0.f) first = seg.t0;
    last = seg.t1;
  }
  EXPECT_NEAR(first, 1.f, 1e-6f);
  EXPECT_NEAR(last, 3.f, 1e-6f);
  w = majorant_walk(b.g, Vec3f(0.f, 5.f, 3.5f), Vec3f(1.f, 0.f, 0.f), kInf);
  EXPECT_FALSE(majorant_next(b.g, b.values.data(), w, seg));
}

// A colour grid (three channels, interleaved) reads in each channel what a one-channel grid of that channel's
// samples reads, bit for bit, trilinear and nearest, zero and clamped outside, at random points in and around
// the cube; its d_max and the majorant walk's densities bound every channel.
TEST(MediumGrid, ColourGridReadsEachChannelAsItsOwnGrid) {
  PCG32 rng(41, 42);
  for (int variant = 0; variant < 4; ++variant) {
    MediumGridDesc colour;
    colour.nx = 4;
    colour.ny = 3;
    colour.nz = 5;
    colour.channels = 3;
    colour.nearest = variant & 1;
    colour.clamp = variant & 2;
    for (int i = 0; i < 60 * 3; ++i) colour.values.push_back(3.f * rng.next_float());
    BuiltGrid bc = build(colour);
    float mx = 0.f;
    for (float v : colour.values) mx = std::max(mx, v);
    EXPECT_FLOAT_EQ(bc.g.max_density, mx);
    for (int ch = 0; ch < 3; ++ch) {
      MediumGridDesc one = colour;
      one.channels = 1;
      one.values.clear();
      for (int i = 0; i < 60; ++i) one.values.push_back(colour.values[size_t(i) * 3 + ch]);
      BuiltGrid b1 = build(one);
      for (int i = 0; i < 500; ++i) {
        const Vec3f p(1.4f * rng.next_float() - 0.2f, 1.4f * rng.next_float() - 0.2f, 1.4f * rng.next_float() - 0.2f);
        ASSERT_EQ(grid_value(bc.g, bc.values.data(), p)[ch], grid_value(b1.g, b1.values.data(), p).x)
            << "variant " << variant << " channel " << ch;
      }
    }
    for (int i = 0; i < 200; ++i) {
      const Vec3f o(-0.5f + 2.f * rng.next_float(), -0.5f + 2.f * rng.next_float(), -0.5f);
      const Vec3f d = normalize(Vec3f(rng.next_float() - 0.5f, rng.next_float() - 0.5f, 1.f));
      MajorantWalk w = majorant_walk(bc.g, o, d, 3.f);
      MajorantSegment seg;
      while (majorant_next(bc.g, bc.values.data(), w, seg))
        for (int k = 0; k <= 16; ++k) {
          const RGB v = grid_value(bc.g, bc.values.data(), o + d * lerpf(k / 16.f, seg.t0, seg.t1));
          ASSERT_LE(max_component(v), seg.d * (1.f + 1e-6f)) << "variant " << variant;
        }
    }
  }
}

// The majorant walk over random rays through a turned 37 x 20 x 9 grid (coarse cells of several samples, and
// of one along z): its segments follow one another without gaps, cover the ray's overlap with the cube (all
// of [0, t_max) for a clamped grid, whose outside parts take d_max), and bound the density at every point of
// them (64 points per segment, the segments' ends included).
TEST(MediumGrid, MajorantWalkCoversTheRayAndBoundsTheDensity) {
  MediumGridDesc gd;
  gd.nx = 37;
  gd.ny = 20;
  gd.nz = 9;
  PCG32 vr(3, 4);
  for (int i = 0; i < 37 * 20 * 9; ++i) gd.values.push_back(vr.next_float() < 0.7f ? 0.f : 5.f * vr.next_float());
  const float c = std::cos(0.7f), s = std::sin(0.7f);
  const float R[3][3] = {{c, 0, s}, {0, 1, 0}, {-s, 0, c}};
  const float sc[3] = {2.f, 1.2f, 0.7f};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) gd.to_world.m[i][k] = R[i][k] * sc[k];
  gd.to_world.m[1][3] = 0.3f;
  for (bool clamp : {false, true}) {
    gd.clamp = clamp;
    BuiltGrid b = build(gd);
    EXPECT_EQ(b.g.mx, 16u);
    EXPECT_EQ(b.g.mz, 9u);
    PCG32 rng(clamp ? 8 : 9, 10);
    long segments = 0, points = 0, hits = 0;
    for (int r = 0; r < 2000; ++r) {
      const Vec3f o(-2.f + 4.f * rng.next_float(), -1.f + 3.f * rng.next_float(), -2.f + 4.f * rng.next_float());
      // Aimed at a point of the cube grown by a fifth on each side, so that most rays cross it and some miss.
      const Vec3f q(-0.2f + 1.4f * rng.next_float(), -0.2f + 1.4f * rng.next_float(), -0.2f + 1.4f * rng.next_float());
      const Vec3f d = normalize(gd.to_world.point(q) - o);
      const float t_max = r % 3 == 0 ? kInf : 4.f * rng.next_float();
      float t0, t1;
      grid_cube_overlap(b.g, o, d, t_max, t0, t1);
      MajorantWalk w = majorant_walk(b.g, o, d, t_max);
      MajorantSegment seg;
      float expect = clamp ? 0.f : t0, end = expect;
      bool any = false;
      while (majorant_next(b.g, b.values.data(), w, seg)) {
        any = true;
        ++segments;
        ASSERT_NEAR(seg.t0, expect, 1e-4f * std::max(1.f, std::fabs(expect))) << "a gap before a segment";
        ASSERT_GT(seg.t1, seg.t0);
        expect = end = seg.t1;
        if (!std::isfinite(seg.t1)) {
          EXPECT_EQ(seg.d, b.g.max_density);
          continue;
        }
        for (int k = 0; k <= 63; ++k) {
          const float t = seg.t0 + (seg.t1 - seg.t0) * float(k) / 63.f;
          ASSERT_LE(grid_value(b.g, b.values.data(), o + d * t).x, seg.d * (1.f + 1e-6f)) << "t " << t;
          ++points;
        }
      }
      if (clamp) {
        EXPECT_TRUE(any);
        if (std::isfinite(t_max)) EXPECT_NEAR(end, t_max, 1e-4f * std::max(1.f, t_max));
      } else if (t0 < t1) {
        ++hits;
        EXPECT_TRUE(any);
        EXPECT_NEAR(end, t1, 1e-4f * std::max(1.f, t1));
      } else {
        EXPECT_FALSE(any);
      }
    }
    // Enough rays cross the cube, each through several cells (its rays' segments outnumber them).
    if (!clamp) {
      EXPECT_GT(hits, 1000);
      EXPECT_GT(segments, 3 * hits);
    }
    EXPECT_GT(points, 100000);
  }
}

TEST(MediumGrid, BuildRejectsBadGrids) {
  MediumGridDesc gd = row({1.f, -1.f});
  EXPECT_THROW(build(gd), InputError);
  gd = row({1.f, 2.f});
  gd.values.pop_back();
  EXPECT_THROW(build(gd), InputError);
  gd = row({1.f});
  gd.to_world.m[2][2] = 0.f;  // singular
  EXPECT_THROW(build(gd), InputError);
  gd = row({1.f, 2.f});
  gd.channels = 2;  // 1 or 3
  EXPECT_THROW(build(gd), InputError);
  gd.channels = 3;  // 2 samples of 3 channels need 6 values
  EXPECT_THROW(build(gd), InputError);
}

namespace {

// A grey medium (sigma_a 0.3, sigma_s 0.7 per unit density) in an 8-sample row stretched over x in [0, 2];
// rays along +x at the row's middle from x = -0.25 (the part before the cube has no medium), the surface at
// t_s = 2.
struct GreyRow {
  BuiltGrid b;
  Medium m{RGB(0.3f), RGB(0.7f), 0.f, 0};
  Vec3f o{-0.25f, 0.5f, 0.5f}, d{1.f, 0.f, 0.f};
  float ts = 2.f;
  GreyRow() {
    MediumGridDesc gd = row({0.2f, 1.5f, 0.f, 0.6f, 2.5f, 0.9f, 0.1f, 1.2f});
    gd.to_world.m[0][0] = 2.f;
    b = build(gd);
  }
  double sigma_t(double t) const {
    return double(grid_value(b.g, b.values.data(), o + d * float(t)).x) * double(medium_sigma_t(m).x);
  }
};

// Bins of the collision distance t in [0, t_s] with their exact probabilities T(a) - T(b), the "other" bin
// the surface, T(t_s).
chi2::Result chi2_of_delta_tracking(const GreyRow& s, float majorant_scale) {
  const MediumGrid g = s.b.g;
  std::vector<float> values = s.b.values;  // the samples, then the majorant grid's cells, scaled
  for (size_t i = g.maj_offset; i < values.size(); ++i) values[i] *= majorant_scale;
  const int bins = 40;
  std::vector<double> tau(bins + 1, 0.0);
  for (int i = 1; i <= bins; ++i)
    tau[i] = tau[i - 1] + integrate([&](double t) { return s.sigma_t(t); }, double(s.ts) * (i - 1) / bins,
                                    double(s.ts) * i / bins, 20000);
  std::vector<double> mass(bins);
  for (int i = 0; i < bins; ++i) mass[i] = std::exp(-tau[i]) - std::exp(-tau[i + 1]);
  chi2::Grid grid{0.0, double(s.ts), 0.0, 1.0, bins, 1};
  chi2::Options opt;
  opt.samples = 1000000;
  opt.n_tests = kNumChi2Tests;
  PCG32 rng(21, 22);
  auto sample = [&]() {
    const int hero = hero_of(rng.next_float());
    MediumSample ms = grid_sample_distance(s.m, &g, values.data(), s.o, s.d, s.ts, hero, rng);
    chi2::Sample2 p;
    p.ok = ms.scattered;
    p.x = ms.t;
    p.y = 0.5;
    return p;
  };
  return chi2::test_2d_masses(grid, sample, mass, opt);
}

}  // namespace

TEST(MediumGrid, DeltaTrackingCollisionsFollowTheDensity) {
  GreyRow s;
  chi2::Result r = chi2_of_delta_tracking(s, 1.f);
  EXPECT_TRUE(r.passed) << r.report;
  // A grey medium's weights are exact: sigma_s / sigma_t at a collision, 1 at the surface.
  PCG32 rng(5, 6);
  for (int i = 0; i < 20000; ++i) {
    MediumSample ms = grid_sample_distance(s.m, &s.b.g, s.b.values.data(), s.o, s.d, s.ts, 1, rng);
    RGB w(1.f), rr(1.f);
    ASSERT_TRUE(medium_update_throughput(ms, w, rr));
    ASSERT_NEAR(w.x, ms.scattered ? 0.7f : 1.f, 1e-5f);
  }
}

TEST(MediumGrid, DeltaTrackingWithTooSmallAMajorantFails) {
  // Negative control: with the majorants at 0.6 of the densities they bound, collisions in the dense samples
  // are too rare (the real-collision probability is clipped at 1), and the same chi-square test rejects it.
  GreyRow s;
  chi2::Result r = chi2_of_delta_tracking(s, 0.6f);
  EXPECT_FALSE(r.passed) << r.report;
}

// Chromatic coefficients in a turned, scaled 5x4x3 grid of random densities, a ray crossing it obliquely:
// with the hero channel uniform and the weight f / avg(p), E[w 1{surface}] = T_c(t_s), E[w 1{scatter}] =
// int sigma_s,c T_c dt and E[w 1{scatter} t] = int t sigma_s,c T_c dt per channel (quadrature along the
// ray), for zero and clamped outsides; and the ratio-tracking transmittance's mean is T_c(t_s), every
// estimate in [0, 1]. Again with a colour density grid (a density per channel, some 0) and an albedo grid
// (3 x 3 x 2 random colours, placed apart: the ray leaves its box, where the albedo is 0 unless clamped):
// sigma_t,c(x) = d_c(x) sigma_t,c and sigma_s(x) = albedo(x) sigma_t(x) in the quadrature. The medium emits
// (a constant Le, or Le times a colour emission grid): the emission the events score has the mean
// int T_c sigma_a,c Le_c dt (medium/medium.h's collision estimator).
TEST(MediumGrid, TrackingIsUnbiasedPerChannel) {
  for (bool colour : {false, true})
  for (bool clamp : {false, true}) {
    SCOPED_TRACE(std::string(colour ? "colour grid and albedo grid" : "one-channel grid") +
                 (clamp ? ", clamped" : ", zero outside"));
    MediumGridDesc gd;
    gd.nx = 5;
    gd.ny = 4;
    gd.nz = 3;
    gd.channels = colour ? 3 : 1;
    PCG32 vr(7, 8);
    for (int i = 0; i < 60 * gd.channels; ++i) gd.values.push_back(i % 7 == 0 ? 0.f : 2.f * vr.next_float());
    gd.clamp = clamp;
    // Rotate 30 degrees about z and scale by (1.5, 1, 0.8), then move by (-0.5, 0, 0.2).
    const float c = std::cos(0.5236f), s = std::sin(0.5236f);
    const float sc[3] = {1.5f, 1.f, 0.8f};
    const float R[3][3] = {{c, -s, 0}, {s, c, 0}, {0, 0, 1}};
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) gd.to_world.m[i][k] = R[i][k] * sc[k];
    gd.to_world.m[0][3] = -0.5f;
    gd.to_world.m[2][3] = 0.2f;
    SceneDesc sd;
    sd.grids.push_back(gd);
    Medium m{RGB(0.2f, 0.6f, 0.1f), RGB(0.5f, 1.0f, 1.8f), 0.f, 0};
    if (colour) {
      MediumGridDesc ad;
      ad.nx = ad.ny = 3;
      ad.nz = 2;
      ad.channels = 3;
      for (int i = 0; i < 18 * 3; ++i) ad.values.push_back(vr.next_float());
      ad.clamp = clamp;
      // The box [-1, 0.6] x [-0.5, 1.5] x [-0.5, 1.5].
      ad.to_world.m[0][0] = 1.6f;
      ad.to_world.m[1][1] = ad.to_world.m[2][2] = 2.f;
      ad.to_world.m[0][3] = -1.f;
      ad.to_world.m[1][3] = ad.to_world.m[2][3] = -0.5f;
      sd.grids.push_back(ad);
      m.albedo_grid = 1;
      // Emission: Le times a 2 x 2 x 2 colour grid over the density grid's own box.
      MediumGridDesc ed;
      ed.nx = ed.ny = ed.nz = 2;
      ed.channels = 3;
      for (int i = 0; i < 8 * 3; ++i) ed.values.push_back(3.f * vr.next_float());
      ed.to_world = gd.to_world;
      sd.grids.push_back(ed);
      m.Le = RGB(0.7f, 1.3f, 2.f);
      m.emission_grid = 2;
    } else {
      m.Le = RGB(1.5f, 0.f, 0.4f);  // constant emission; none in green
    }
    std::vector<MediumGrid> grids;
    std::vector<float> values;
    build_medium_grids(sd, grids, values);
    const Vec3f o(-1.2f, 0.1f, 0.5f), d = normalize(Vec3f(1.f, 0.45f, -0.1f));
    const float ts = 2.6f;
    auto coeff = [&](double t) { return grid_coefficients(m, grids.data(), values.data(), o + d * float(t)); };
    // e_scat_const: what E[w 1{scatter}] would be with the constant albedo in place of the albedo grid (the
    // power check below: the estimates must be far from it). e_emit: int T sigma_a Le dt, the emission the
    // events score (medium_event_emission).
    double e_surf[3], e_scat[3], e_scat_t[3], e_scat_const[3], e_emit[3];
    for (int ch = 0; ch < 3; ++ch) {
      // Running optical depth on a fine grid of t, for T(t) inside the integrals.
      const int n = 100000;
      const double h = ts / n;
      GridCoefficients k0 = coeff(0.0);
      double tau = 0.0, scat = 0.0, scat_t = 0.0, scat_const = 0.0, emit = 0.0;
      auto source = [&](double t, const GridCoefficients& k) {  // sigma_a(t) Le(t) in channel ch
        const Vec3f x = o + d * float(t);
        const double le = m.Le[ch] * (m.emission_grid >= 0 ? grid_value(grids[2], values.data(), x)[ch] : 1.f);
        return (double(k.sigma_t[ch]) - double(k.sigma_s[ch])) * le;
      };
      double src0 = source(0.0, k0);
      const double albedo_const = m.sigma_s[ch] / medium_sigma_t(m)[ch];
      for (int i = 1; i <= n; ++i) {
        const double t = h * i;
        const GridCoefficients k1 = coeff(t);
        const double tau_next = tau + 0.5 * h * (double(k0.sigma_t[ch]) + double(k1.sigma_t[ch]));
        // Trapezoid on sigma_s(t) T(t) (and times t) over [t - h, t].
        const double a = k0.sigma_s[ch] * std::exp(-tau), bb = k1.sigma_s[ch] * std::exp(-tau_next);
        scat += 0.5 * h * (a + bb);
        scat_t += 0.5 * h * ((t - h) * a + t * bb);
        const double src1 = source(t, k1);
        emit += 0.5 * h * (src0 * std::exp(-tau) + src1 * std::exp(-tau_next));
        src0 = src1;
        scat_const +=
            0.5 * h * albedo_const * (k0.sigma_t[ch] * std::exp(-tau) + k1.sigma_t[ch] * std::exp(-tau_next));
        tau = tau_next;
        k0 = k1;
      }
      e_surf[ch] = std::exp(-tau);
      e_scat[ch] = scat;
      e_scat_t[ch] = scat_t;
      e_scat_const[ch] = scat_const;
      e_emit[ch] = emit;
    }
    PCG32 rng(clamp ? 31 : 32, colour ? 34 : 33);
    Moments surf[3], sc_[3], sc_t[3], tr[3], em[3];
    float tr_min = 1.f, tr_max = 0.f;
    const long N = 400000;
    for (long i = 0; i < N; ++i) {
      const int hero = hero_of(rng.next_float());
      MediumSample ms = grid_sample_distance(m, grids.data(), values.data(), o, d, ts, hero, rng);
      RGB w(1.f), r(1.f);
      const RGB e = medium_event_emission(ms, w, r);
      ASSERT_TRUE(medium_update_throughput(ms, w, r));
      const RGB T = grid_transmittance(m, grids.data(), values.data(), o, d, ts, rng);
      for (int ch = 0; ch < 3; ++ch) {
        surf[ch].add(ms.scattered ? 0.0 : w[ch]);
        sc_[ch].add(ms.scattered ? w[ch] : 0.0);
        sc_t[ch].add(ms.scattered ? w[ch] * ms.t : 0.0);
        tr[ch].add(T[ch]);
        em[ch].add(e[ch]);
        tr_min = std::min(tr_min, T[ch]);
        tr_max = std::max(tr_max, T[ch]);
      }
    }
    for (int ch = 0; ch < 3; ++ch) {
      // 4 standard errors of each mean (+1e-6 for the quadrature).
      EXPECT_NEAR(surf[ch].mean(), e_surf[ch], 4 * surf[ch].se() + 1e-6) << "clamp " << clamp << " channel " << ch;
      EXPECT_NEAR(sc_[ch].mean(), e_scat[ch], 4 * sc_[ch].se() + 1e-6) << "clamp " << clamp << " channel " << ch;
      EXPECT_NEAR(sc_t[ch].mean(), e_scat_t[ch], 4 * sc_t[ch].se() + 1e-6) << "clamp " << clamp << " channel " << ch;
      EXPECT_NEAR(tr[ch].mean(), e_surf[ch], 4 * tr[ch].se() + 1e-6) << "clamp " << clamp << " channel " << ch;
      EXPECT_NEAR(em[ch].mean(), e_emit[ch], 4 * em[ch].se() + 1e-6) << "clamp " << clamp << " channel " << ch;
    }
    // The albedo grid matters here: ignoring it would be off by more than 10 standard errors in some channel.
    if (colour) {
      double worst = 0.0;
      for (int ch = 0; ch < 3; ++ch)
        worst = std::max(worst, std::fabs(sc_[ch].mean() - e_scat_const[ch]) / sc_[ch].se());
      EXPECT_GT(worst, 10.0);
    }
    // Every estimate in [0, 1]: the factors are, and roulette divides by the largest channel, which is then 1.
    EXPECT_GE(tr_min, 0.f);
    EXPECT_LE(tr_max, 1.f + 1e-6f);
  }
}
