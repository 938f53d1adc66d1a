// Tests of the photon maps: the 16-byte compact photon (octahedral directions, Cigolle et al. 2014, "A Survey
// of Efficient Representations for Independent Unit Vectors"; shared-exponent power, EXT_texture_shared_
// exponent), the sorted spatial hash grid and its stochastic variant (Hachisuka and Jensen 2010, "Parallel
// Progressive Photon Mapping on GPUs"), and the kd-tree for Jensen's photon mapping (Jensen 1996, "Global
// Illumination using Photon Maps", on nanoflann).
//
// Queries are compared with brute-force scans that use the same distance expression (photon_dist2), so the
// expected answer is exact: any missed, extra or duplicated photon fails. Clouds: uniform, clustered with
// exact duplicates, on planes (one axis of zero extent), and an exactly representable lattice whose
// photons sit at exactly the query radius and on cell boundaries. All random numbers come from fixed seeds.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <vector>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "caustica/base/rng.h"
#include "caustica/photon/compact_photon.h"
#include "caustica/photon/hash_grid.h"
#include "caustica/photon/kdtree.h"
#include "caustica/photon/knn_tree.h"

using namespace caustica;

namespace {

float uni(PCG32& rng, float a, float b) { return a + (b - a) * rng.next_float(); }

Vec3f uniform_sphere(PCG32& rng) {
  float z = 1.f - 2.f * rng.next_float();
  float r = std::sqrt(std::max(0.f, 1.f - z * z));
  float phi = 2.f * kPi * rng.next_float();
  return {r * std::cos(phi), r * std::sin(phi), z};
}

Photon random_photon(PCG32& rng, Vec3f p) {
  Photon ph;
  ph.p = p;
  ph.wi = uniform_sphere(rng);
  ph.power = RGB(uni(rng, 0.f, 2.f), uni(rng, 0.f, 2.f), uni(rng, 0.f, 2.f));
  ph.flags = (rng.next_u32() & 3u) | photon_segment_bits(1 + rng.next_u32() % 40);
  return ph;
}

enum class Cloud { Uniform, Clustered, Planes, Lattice };
const char* cloud_name(Cloud c) {
  switch (c) {
    case Cloud::Uniform: return "uniform";
    case Cloud::Clustered: return "clustered";
    case Cloud::Planes: return "planes";
    default: return "lattice";
  }
}

// The lattice: coordinates k / 4, k in [0, 64), inside bounds [0, 65535/256] on every axis, so that the
// quantization step is exactly 1/256 and every lattice point (and every distance between two of them) is
// exact: many photons lie at exactly the query radius and exactly on cell boundaries.
constexpr float kLatticeHi = 65535.f / 256.f;

std::vector<Photon> make_cloud(Cloud kind, size_t n, uint64_t seed, Bounds3& bounds) {
  PCG32 rng(seed, 7);
  std::vector<Photon> out;
  out.reserve(n);
  bounds = Bounds3();
  switch (kind) {
    case Cloud::Uniform:
      bounds.extend(Vec3f(-2.f, 0.f, 3.f));
      bounds.extend(Vec3f(1.f, 1.f, 5.f));
      for (size_t i = 0; i < n; ++i)
        out.push_back(random_photon(rng, Vec3f(uni(rng, -2.f, 1.f), uni(rng, 0.f, 1.f), uni(rng, 3.f, 5.f))));
      break;
    case Cloud::Clustered: {
      // 12 tight blobs (uniform in cubes of side 0.02 .. 0.2), one photon in eight an exact copy of an earlier one.
      bounds.extend(Vec3f(0.f));
      bounds.extend(Vec3f(4.f));
      Vec3f centre[12];
      float half[12];
      for (int c = 0; c < 12; ++c) {
        centre[c] = Vec3f(uni(rng, 0.3f, 3.7f), uni(rng, 0.3f, 3.7f), uni(rng, 0.3f, 3.7f));
        half[c] = uni(rng, 0.01f, 0.1f);
      }
      for (size_t i = 0; i < n; ++i) {
        if (i > 0 && rng.next_u32() % 8 == 0) {
          Photon dup = out[rng.next_u32() % i];
          dup.power = dup.power * 0.5f;
          out.push_back(dup);
          continue;
        }
        int c = int(rng.next_u32() % 12);
        Vec3f d(uni(rng, -half[c], half[c]), uni(rng, -half[c], half[c]), uni(rng, -half[c], half[c]));
        out.push_back(random_photon(rng, centre[c] + d));
      }
      break;
    }
    case Cloud::Planes:
      // All on the plane y = 0.5 (so the y extent is zero), half of them on the line x = z there too.
      bounds.extend(Vec3f(0.f, 0.5f, 0.f));
      bounds.extend(Vec3f(2.f, 0.5f, 2.f));
      for (size_t i = 0; i < n; ++i) {
        float x = uni(rng, 0.f, 2.f);
        float z = (i % 2 == 0) ? x : uni(rng, 0.f, 2.f);
        out.push_back(random_photon(rng, Vec3f(x, 0.5f, z)));
      }
      break;
    case Cloud::Lattice:
      bounds.extend(Vec3f(0.f));
      bounds.extend(Vec3f(kLatticeHi));
      for (size_t i = 0; i < n; ++i) {
        Vec3f p(float(rng.next_u32() % 64) * 0.25f, float(rng.next_u32() % 64) * 0.25f, float(rng.next_u32() % 8) * 0.25f);
        out.push_back(random_photon(rng, p));
      }
      break;
  }
  return out;
}

// Query points: a third at photons (distance 0 included) or jittered photons, a third anywhere in the
// bounds, a third outside them (up to half the extent beyond, and a few far away). For the lattice, lattice
// points (so that whole shells of photons lie at exactly the radius).
std::vector<Vec3f> make_queries(Cloud kind, const std::vector<Photon>& photons, const Bounds3& b, size_t n,
                                uint64_t seed) {
  PCG32 rng(seed, 11);
  std::vector<Vec3f> q;
  Vec3f ext = b.diagonal();
  for (size_t i = 0; i < n; ++i) {
    if (kind == Cloud::Lattice && i % 3 != 2) {
      q.push_back(Vec3f(float(rng.next_u32() % 70) * 0.25f - 0.5f, float(rng.next_u32() % 70) * 0.25f - 0.5f,
                        float(rng.next_u32() % 12) * 0.25f - 0.5f));
      continue;
    }
    switch (i % 3) {
      case 0: {
        Vec3f p = photons[rng.next_u32() % photons.size()].p;
        if (rng.next_u32() % 2) p = p + Vec3f(uni(rng, -0.01f, 0.01f), uni(rng, -0.01f, 0.01f), uni(rng, -0.01f, 0.01f));
        q.push_back(p);
        break;
      }
      case 1:
        q.push_back(Vec3f(uni(rng, b.lo.x, b.hi.x), uni(rng, b.lo.y, b.hi.y), uni(rng, b.lo.z, b.hi.z)));
        break;
      default: {
        Vec3f lo = b.lo - ext * 0.5f - Vec3f(0.1f), hi = b.hi + ext * 0.5f + Vec3f(0.1f);
        Vec3f p(uni(rng, lo.x, hi.x), uni(rng, lo.y, hi.y), uni(rng, lo.z, hi.z));
        if (rng.next_u32() % 10 == 0) p = p * 1000.f;
        q.push_back(p);
      }
    }
  }
  return q;
}

using PhotonBits = std::array<uint32_t, 10>;
PhotonBits bits_of(const Photon& ph) {
  PhotonBits k;
  const float f[9] = {ph.p.x, ph.p.y, ph.p.z, ph.wi.x, ph.wi.y, ph.wi.z, ph.power.x, ph.power.y, ph.power.z};
  std::memcpy(k.data(), f, sizeof(f));
  k[9] = ph.flags;
  return k;
}

double angle_between(Vec3f a, Vec3f b) {
  double ax = a.x, ay = a.y, az = a.z, bx = b.x, by = b.y, bz = b.z;
  double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
  return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz);
}

float ulp_of(float x) { return std::nextafter(std::fabs(x), kInf) - std::fabs(x); }

// The documented worst-case errors (compact_photon.h).
const double kDirectionBound = 3.0 / (32767.0 * std::sqrt(2.0)) + 2e-7;  // + float rounding of decode
float power_tolerance(float maxc) { return std::max(maxc / 511.5f * (1.f + 0x1p-20f), 0x1p-137f); }

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// CompactPhoton

TEST(PhotonCompact, FitsIn16Bytes) { EXPECT_LE(sizeof(CompactPhoton), 16u); }

TEST(PhotonCompact, RoundTripWithinTheStatedBounds) {
  PCG32 rng(2024, 1);
  Bounds3 b;
  b.extend(Vec3f(-3.f, 0.f, 10.f));
  b.extend(Vec3f(5.f, 1.f, 1000.f));
  PhotonQuantizer qz = make_photon_quantizer(b);

  std::vector<Vec3f> dirs;
  // Poles, the equator (where the lower half folds), the axes planes x = 0 and y = 0 (the sign seams of the
  // fold), the diagonals, each also nudged by +-1e-7 and +-1e-4.
  const Vec3f special[] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0},
                           {1, 1, 0}, {1, -1, 0}, {-1, 1, 0}, {-1, -1, 0}, {1, 1, 1}, {-1, -1, -1},
                           {0, 1, -1}, {0, -1, -1}, {1, 0, -1}, {-1, 0, -1}, {1, 1, -1}, {-1, 1, -1}};
  for (Vec3f s : special) {
    for (float eps : {0.f, 1e-7f, -1e-7f, 1e-4f, -1e-4f}) {
      dirs.push_back(normalize(s + Vec3f(eps, -eps, eps)));
      dirs.push_back(normalize(s + Vec3f(eps, eps, -eps)));
    }
  }
  for (int i = 0; i < 20000; ++i) {  // near the poles and on the seams, randomly
    float t = uni(rng, -1e-3f, 1e-3f), u = uni(rng, -1e-3f, 1e-3f);
    float sz = (i % 2) ? 1.f : -1.f;
    dirs.push_back(normalize(Vec3f(t, u, sz)));                          // poles
    dirs.push_back(normalize(Vec3f(uni(rng, -1.f, 1.f), t, u)));         // y = 0 and z = 0 seams
    dirs.push_back(normalize(Vec3f(t, uni(rng, -1.f, 1.f), -std::fabs(u))));
  }
  for (int i = 0; i < 200000; ++i) dirs.push_back(uniform_sphere(rng));

  double max_angle = 0.0, max_pos_steps = 0.0, max_power_rel = 0.0;
  for (size_t i = 0; i < dirs.size(); ++i) {
    Photon ph;
    ph.p = Vec3f(uni(rng, b.lo.x, b.hi.x), uni(rng, b.lo.y, b.hi.y), uni(rng, b.lo.z, b.hi.z));
    if (i % 97 == 0) ph.p = (i % 2) ? b.lo : b.hi;  // the corners
    ph.wi = dirs[i];
    switch (i % 8) {
      case 0: ph.power = RGB(0.f); break;                                        // zero
      case 1: ph.power = RGB(1e-30f, 3e-31f, 0.f); break;                        // tiny
      case 2: ph.power = RGB(1e6f, 2.5e5f, 1e6f); break;                         // huge
      case 3: ph.power = RGB(1e30f, 1e-3f, 7e29f); break;                        // huge, wide ratio
      case 4: ph.power = RGB(1.2e-38f, 0.f, 4e-39f); break;                      // at float's normal limit
      default: {                                                                 // log-uniform, 1e-20..1e20
        float e = uni(rng, -20.f, 20.f);
        ph.power = RGB(std::pow(10.f, e) * uni(rng, 0.f, 1.f), std::pow(10.f, e) * uni(rng, 0.f, 1.f),
                       std::pow(10.f, e) * uni(rng, 0.f, 1.f));
      }
    }
    // Bit 2 (kPhotonVolume) is dropped; the segments go through every value of the 11 bits, and above them
    // they saturate at 2047 (compact_photon.h).
    const uint32_t segments = uint32_t(i) % 2100 + (i % 97 == 0 ? 70000 : 0);
    ph.flags = (uint32_t(i) & 7u) | photon_segment_bits(segments);
    Photon d = decode_photon(encode_photon(ph, qz), qz);

    for (int a = 0; a < 3; ++a) {
      // Half a step plus 2^-6 step of float rounding in the encoder, plus 2 ulps of the decoder (compact_photon.h).
      float tol = (0.5f + 0x1p-6f) * qz.step[a] + 2.f * ulp_of(std::max(std::fabs(b.lo[a]), std::fabs(b.hi[a])));
      ASSERT_LE(std::fabs(d.p[a] - ph.p[a]), tol) << "axis " << a << " photon " << i;
      max_pos_steps = std::max(max_pos_steps, double(std::fabs(d.p[a] - ph.p[a]) / qz.step[a]));
    }
    double ang = angle_between(d.wi, ph.wi);
    ASSERT_LE(ang, kDirectionBound) << "direction " << ph.wi.x << " " << ph.wi.y << " " << ph.wi.z;
    ASSERT_NEAR(length(d.wi), 1.f, 3e-7f);  // normalised (a few float roundings)
    max_angle = std::max(max_angle, ang);

    float maxc = max_component(ph.power);
    for (int c = 0; c < 3; ++c) {
      ASSERT_LE(std::fabs(d.power[c] - ph.power[c]), power_tolerance(maxc)) << "channel " << c << " photon " << i;
      if (maxc > 0.f) max_power_rel = std::max(max_power_rel, double(std::fabs(d.power[c] - ph.power[c]) / maxc));
    }
    if (is_black(ph.power)) {
      ASSERT_TRUE(is_black(d.power));
    }
    ASSERT_EQ(d.flags & kPhotonFlagBits, ph.flags & 3u);
    ASSERT_EQ(photon_segments(d), std::min(std::min(segments, 65535u), kCompactMaxSegments)) << segments;
  }
  std::printf("[ measured ] max direction error %.3g rad (bound %.3g), max position error %.4f steps (bound 0.516),"
              " max power error %.5f of the largest channel (bound %.5f)\n",
              max_angle, kDirectionBound, max_pos_steps, max_power_rel, 1.0 / 511.5);
  // The derived bound should be within a small factor of what is attained; a bound 10x too loose would mean
  // the derivation, not the code, is wrong.
  EXPECT_GT(max_angle, kDirectionBound / 10);
  EXPECT_GT(max_power_rel, 0.5 / 511.5);  // rounding to nearest reaches close to half a step of 2^-8
}

TEST(PhotonCompact, PowerEdgeCases) {
  // Exactly representable values survive exactly; NaN and negative become 0; +inf clamps to the maximum.
  auto rt = [](RGB c) {
    SharedExpRGB s = encode_shared_exp(c);
    return decode_shared_exp(s.rgb, s.exp);
  };
  RGB a = rt(RGB(1.f, 0.5f, 0.25f));
  EXPECT_EQ(a.x, 1.f);
  EXPECT_EQ(a.y, 0.5f);
  EXPECT_EQ(a.z, 0.25f);
  RGB big = rt(RGB(1e6f, 0.f, 0.f));
  // 1e6 lies in [2^19, 2^20): denom = 2^(19 + 1 - 9) = 2^11, 1e6 / 2^11 = 488.28 rounds to 488, 488 * 2^11 = 999424.
  EXPECT_EQ(big.x, 999424.f);
  RGB nanneg = rt(RGB(std::numeric_limits<float>::quiet_NaN(), -1.f, 2.f));
  EXPECT_EQ(nanneg.x, 0.f);
  EXPECT_EQ(nanneg.y, 0.f);
  EXPECT_EQ(nanneg.z, 2.f);
  RGB inf = rt(RGB(kInf, 1.f, 0.f));
  EXPECT_EQ(inf.x, kSharedExpMaxValue);
  EXPECT_EQ(inf.y, 0.f);  // 1 is far below the shared exponent's step
}

// ---------------------------------------------------------------------------------------------------------
// Hash grid

namespace {

// The photons a query must return: every stored photon, decoded, within radius (the same inclusive test
// with the same photon_dist2 as the grid), as a sorted multiset of bit patterns.
std::vector<PhotonBits> brute_force_grid(const std::vector<Photon>& decoded, Vec3f p, float radius) {
  std::vector<PhotonBits> out;
  for (const Photon& ph : decoded)
    if (photon_dist2(p, ph.p) <= radius * radius) out.push_back(bits_of(ph));
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Photon> decode_all(const PhotonHashGrid& grid) {
  std::vector<Photon> d;
  for (const CompactPhoton& c : grid.photons()) d.push_back(decode_photon(c, grid.quantizer()));
  return d;
}

}  // namespace

TEST(PhotonHashGrid, StoresEveryPhotonInItsSlot) {
  Bounds3 b;
  std::vector<Photon> photons = make_cloud(Cloud::Clustered, 30000, 5, b);
  PhotonHashGrid grid;
  grid.build(photons, b, 0.05f);
  ASSERT_EQ(grid.size(), photons.size());
  // Table: the smallest power of two >= 2N = 60000 is 65536.
  EXPECT_EQ(grid.table_size(), 65536u);
  EXPECT_EQ(grid.cell_start().front(), 0u);
  EXPECT_EQ(grid.cell_start().back(), photons.size());
  // The stored records are exactly the encoded input photons (as a multiset).
  std::vector<PhotonBits> in, stored;
  for (const Photon& ph : photons) in.push_back(bits_of(decode_photon(encode_photon(ph, grid.quantizer()), grid.quantizer())));
  for (const Photon& ph : decode_all(grid)) stored.push_back(bits_of(ph));
  std::sort(in.begin(), in.end());
  std::sort(stored.begin(), stored.end());
  EXPECT_TRUE(in == stored);
  // Each photon lies in the run of the slot of its cell.
  PhotonGridView v = grid.view();
  for (uint32_t s = 0; s < grid.table_size(); ++s) {
    ASSERT_LE(v.cell_start[s], v.cell_start[s + 1]);
    for (uint32_t j = v.cell_start[s]; j < v.cell_start[s + 1]; ++j)
      ASSERT_EQ(grid_slot(v.cell_of(decode_position(v.photons[j].q, v.quant)), v.table_mask), s);
  }
  EXPECT_GE(grid.bytes(), grid.size() * sizeof(CompactPhoton) + (grid.table_size() + 1) * sizeof(uint32_t));
}

// Every query returns exactly the stored photons within the radius, once each: all cloud kinds, cell sizes
// from 1x to 20x the radius (the query visits 2^3 cells when cell_size >= 2r, up to 3^3..4^3 when r =
// cell_size), queries inside and outside the cloud, with and without stochastic hashing.
TEST(PhotonHashGrid, QueryEqualsBruteForce) {
  struct Config {
    float cell_size, radius;
  };
  size_t total_found = 0, total_queries = 0, at_radius = 0;
  for (Cloud kind : {Cloud::Uniform, Cloud::Clustered, Cloud::Planes, Cloud::Lattice}) {
    Bounds3 b;
    std::vector<Photon> photons = make_cloud(kind, 20000, 100 + int(kind), b);
    std::vector<Config> configs;
    if (kind == Cloud::Lattice)  // exact radii: photons at exactly r, cell walls through lattice points
      configs = {{0.5f, 0.5f}, {1.f, 0.5f}, {1.f, 1.f}, {2.f, 1.f}, {0.75f, 0.5f}, {0.25f, 0.25f}};
    else
      configs = {{0.1f, 0.05f}, {0.1f, 0.1f}, {0.1f, 0.037f}, {0.04f, 0.02f}, {0.3f, 0.015f}, {0.013f, 0.013f}};
    for (bool stochastic : {false, true}) {
      for (const Config& cfg : configs) {
        PhotonHashGrid grid;
        grid.build(photons, b, cfg.cell_size, stochastic, 77);
        std::vector<Photon> decoded = decode_all(grid);
        PhotonGridView v = grid.view();
        std::vector<Vec3f> queries = make_queries(kind, photons, b, 300, 9 + int(kind));
        for (size_t qi = 0; qi < queries.size(); ++qi) {
          Vec3f p = queries[qi];
          std::vector<PhotonBits> got;
          query(v, p, cfg.radius, [&](const Photon& ph) { got.push_back(bits_of(ph)); });
          std::sort(got.begin(), got.end());
          std::vector<PhotonBits> want = brute_force_grid(decoded, p, cfg.radius);
          ASSERT_EQ(got.size(), want.size()) << cloud_name(kind) << " stochastic " << stochastic << " cell "
                                             << cfg.cell_size << " radius " << cfg.radius << " query " << qi;
          ASSERT_TRUE(got == want) << cloud_name(kind) << " query " << qi;
          // query_any: true exactly when a reported photon satisfies the predicate (here: any photon; and
          // one in the upper half of the radius, whose answer differs from "any" for some queries).
          EXPECT_EQ(v.query_any(p, cfg.radius, [](uint32_t, const Photon&) { return true; }), !want.empty());
          auto outer = [&](const Photon& ph) { return photon_dist2(p, ph.p) > 0.25f * cfg.radius * cfg.radius; };
          bool any_outer = false;
          query(v, p, cfg.radius, [&](const Photon& ph) { any_outer = any_outer || outer(ph); });
          EXPECT_EQ(v.query_any(p, cfg.radius, [&](uint32_t, const Photon& ph) { return outer(ph); }), any_outer);
          total_found += got.size();
          ++total_queries;
          for (const Photon& ph : decoded) at_radius += photon_dist2(p, ph.p) == cfg.radius * cfg.radius;
        }
      }
    }
  }
  std::printf("[ measured ] %zu queries, %.1f photons per query on average, %zu photons at exactly the radius\n",
              total_queries, double(total_found) / double(total_queries), at_radius);
  // The test must have exercised non-empty answers and the boundary case.
  EXPECT_GT(total_found, 10 * total_queries);
  EXPECT_GT(at_radius, 1000u);
}

TEST(PhotonHashGrid, EmptyAndSingle) {
  PhotonHashGrid grid;
  Bounds3 b;
  b.extend(Vec3f(0.f));
  b.extend(Vec3f(1.f));
  grid.build({}, b, 0.1f);
  EXPECT_EQ(grid.size(), 0u);
  int calls = 0;
  query(grid.view(), Vec3f(0.5f), 0.1f, [&](const Photon&) { ++calls; });
  EXPECT_EQ(calls, 0);
  Photon one;
  one.p = Vec3f(0.25f);
  one.wi = Vec3f(0, 0, 1);
  one.power = RGB(1.f);
  grid.build({one}, b, 0.1f);
  query(grid.view(), Vec3f(0.25f, 0.25f, 0.3f), 0.1f, [&](const Photon& ph) {
    ++calls;
    EXPECT_EQ(ph.power.x, 1.f);
  });
  EXPECT_EQ(calls, 1);
  EXPECT_THROW(grid.build({one}, b, 0.f), std::invalid_argument);
}

// The arrays do not depend on the number of threads (1, 2, and 8 in an oversubscribed arena).
TEST(PhotonHashGrid, BuildIsDeterministicAcrossThreadCounts) {
  Bounds3 b;
  std::vector<Photon> photons = make_cloud(Cloud::Clustered, 300000, 31, b);
  for (bool stochastic : {false, true}) {
    PhotonHashGrid g1, g2, g8;
    {
      tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
      g1.build(photons, b, 0.02f, stochastic, 5);
    }
    {
      tbb::task_arena two(2);
      two.execute([&] { g2.build(photons, b, 0.02f, stochastic, 5); });
    }
    {
      tbb::global_control eight(tbb::global_control::max_allowed_parallelism, 8);
      tbb::task_arena arena(8);
      arena.execute([&] { g8.build(photons, b, 0.02f, stochastic, 5); });
    }
    for (const PhotonHashGrid* g : {&g2, &g8}) {
      ASSERT_EQ(g1.size(), g->size());
      EXPECT_EQ(0, std::memcmp(g1.photons().data(), g->photons().data(), g1.size() * sizeof(CompactPhoton)));
      EXPECT_TRUE(g1.cell_start() == g->cell_start());
    }
  }
}

// Stochastic hashing keeps exactly one photon per occupied cell, and it is one of that cell's photons.
// With equal powers in a cell the kept power n * Phi equals the cell's total up to the shared-exponent
// rounding; with unequal powers it equals it in expectation over seeds.
TEST(PhotonHashGrid, StochasticKeepsOnePhotonPerCell) {
  Bounds3 b;
  std::vector<Photon> photons = make_cloud(Cloud::Clustered, 50000, 41, b);
  const RGB phi(0.3f, 0.5f, 0.7f);
  for (Photon& ph : photons) ph.power = phi;
  PhotonHashGrid grid;
  grid.build(photons, b, 0.03f, true, 123);
  PhotonGridView v = grid.view();
  const PhotonQuantizer& qz = grid.quantizer();

  // The cells of the input (from the decoded positions, as the grid files them) and their photons' records.
  std::map<uint64_t, size_t> count;
  std::map<uint64_t, std::set<std::array<uint32_t, 6>>> members;
  for (const Photon& ph : photons) {
    CompactPhoton c = encode_photon(ph, qz);
    uint64_t cell = v.cell_of(decode_position(c.q, qz));
    ++count[cell];
    members[cell].insert({c.q[0], c.q[1], c.q[2], c.oct[0], c.oct[1], compact_flags(c)});
  }
  ASSERT_EQ(grid.size(), count.size());
  // The table is sized for the kept photons, not the input: the smallest power of two >= 2 x kept.
  EXPECT_GE(grid.table_size(), 2 * grid.size());
  EXPECT_LT(grid.table_size(), 4 * grid.size());
  std::set<uint64_t> seen;
  double kept_total[3] = {0, 0, 0}, bound_total = 0;
  for (const CompactPhoton& c : grid.photons()) {
    uint64_t cell = v.cell_of(decode_position(c.q, qz));
    ASSERT_TRUE(seen.insert(cell).second) << "two photons kept in one cell";
    ASSERT_TRUE(count.count(cell));
    ASSERT_TRUE(members[cell].count({c.q[0], c.q[1], c.q[2], c.oct[0], c.oct[1], compact_flags(c)}))
        << "the kept photon is not one of its cell's photons";
    RGB kept = compact_power(c);
    RGB want = phi * float(count[cell]);
    for (int ch = 0; ch < 3; ++ch) {
      // n * Phi in float (exact to 1 ulp) stored with the shared exponent: error <= maxc / 511.5.
      float tol = power_tolerance(max_component(want)) + ulp_of(want[ch]);
      ASSERT_NEAR(kept[ch], want[ch], tol) << "cell with " << count[cell] << " photons";
      kept_total[ch] += kept[ch];
    }
    bound_total += power_tolerance(max_component(want)) + ulp_of(max_component(want));
  }
  // Conservation of the total power: sum of the kept powers vs N * Phi, within the sum of the per-cell
  // bounds (the roundings may all go one way).
  for (int ch = 0; ch < 3; ++ch)
    EXPECT_NEAR(kept_total[ch], double(phi[ch]) * double(photons.size()), bound_total) << "channel " << ch;
}

TEST(PhotonHashGrid, StochasticIsUnbiasedPerCellOverSeeds) {
  // A few hundred photons of random power in cells of side 0.25 in the unit cube (64 cells).
  PCG32 rng(99, 3);
  std::vector<Photon> photons;
  for (int i = 0; i < 600; ++i) photons.push_back(random_photon(rng, Vec3f(uni(rng, 0.f, 1.f), uni(rng, 0.f, 1.f), uni(rng, 0.f, 1.f))));
  Bounds3 b;
  b.extend(Vec3f(0.f));
  b.extend(Vec3f(1.f));
  const float cs = 0.25f;
  PhotonHashGrid probe;
  probe.build(photons, b, cs);
  PhotonGridView pv = probe.view();
  // Per cell: the total power (of the full-precision photons), n, and sum of squares for the variance.
  struct Cell {
    double sum[3] = {0, 0, 0}, sumsq[3] = {0, 0, 0}, kept[3] = {0, 0, 0};
    double n = 0;
  };
  std::map<uint64_t, Cell> cells;
  for (const Photon& ph : photons) {
    Cell& c = cells[pv.cell_of(decode_position(encode_photon(ph, probe.quantizer()).q, probe.quantizer()))];
    c.n += 1;
    for (int ch = 0; ch < 3; ++ch) {
      c.sum[ch] += ph.power[ch];
      c.sumsq[ch] += double(ph.power[ch]) * ph.power[ch];
    }
  }
  const int seeds = 400;
  for (int s = 0; s < seeds; ++s) {
    PhotonHashGrid g;
    g.build(photons, b, cs, true, uint64_t(s) * 7919u + 1u);
    PhotonGridView v = g.view();
    ASSERT_EQ(g.size(), cells.size());
    for (const CompactPhoton& c : g.photons()) {
      Cell& cell = cells.at(v.cell_of(decode_position(c.q, g.quantizer())));
      RGB p = compact_power(c);
      for (int ch = 0; ch < 3; ++ch) cell.kept[ch] += p[ch];
    }
  }
  int checked = 0;
  for (auto& [key, c] : cells) {
    for (int ch = 0; ch < 3; ++ch) {
      double mean = c.kept[ch] / seeds;
      // The kept power is n * Phi_k, k uniform among n: variance n^2 Var(Phi) = n sum Phi^2 - (sum Phi)^2.
      double var = std::max(0.0, c.n * c.sumsq[ch] - c.sum[ch] * c.sum[ch]);
      // 5 standard errors of the mean over the seeds (about 190 comparisons, so a correct implementation
      // fails one with probability ~1e-4), plus the shared-exponent rounding: at most 2 * n / 511.5 with
      // powers below 2.
      double tol = 5.0 * std::sqrt(var / seeds) + 2.0 * c.n / 511.5;
      EXPECT_NEAR(mean, c.sum[ch], tol) << "cell of " << c.n << " photons, channel " << ch;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 3 * 64);
}

// ---------------------------------------------------------------------------------------------------------
// Kd-tree

TEST(PhotonKdTree, RangeEqualsBruteForce) {
  std::vector<uint32_t> got, want;
  size_t total = 0, queries_done = 0;
  for (Cloud kind : {Cloud::Uniform, Cloud::Clustered, Cloud::Planes, Cloud::Lattice}) {
    Bounds3 b;
    std::vector<Photon> photons = make_cloud(kind, 20000, 200 + int(kind), b);
    PhotonKdTree tree;
    tree.build(photons);
    ASSERT_EQ(tree.size(), photons.size());
    for (size_t i = 0; i < photons.size(); i += 997) ASSERT_EQ(bits_of(tree.photon(uint32_t(i))), bits_of(photons[i]));
    std::vector<float> radii = kind == Cloud::Lattice ? std::vector<float>{0.f, 0.25f, 0.5f, 1.f}
                                                      : std::vector<float>{0.f, 0.01f, 0.05f, 0.2f};
    std::vector<Vec3f> queries = make_queries(kind, photons, b, 300, 19 + int(kind));
    for (float r : radii) {
      for (size_t qi = 0; qi < queries.size(); ++qi) {
        Vec3f p = queries[qi];
        tree.range(p, r, got);
        want.clear();
        for (uint32_t i = 0; i < photons.size(); ++i)
          if (photon_dist2(p, photons[i].p) <= r * r) want.push_back(i);
        std::sort(got.begin(), got.end());
        ASSERT_TRUE(got == want) << cloud_name(kind) << " radius " << r << " query " << qi << ": " << got.size()
                                 << " vs " << want.size();
        total += got.size();
        ++queries_done;
      }
    }
  }
  EXPECT_GT(total, 10 * queries_done);
}

TEST(PhotonKdTree, KnnEqualsBruteForce) {
  std::vector<uint32_t> idx;
  std::vector<float> d2;
  std::vector<std::pair<float, uint32_t>> all;
  size_t ties_at_kth = 0;
  for (Cloud kind : {Cloud::Uniform, Cloud::Clustered, Cloud::Planes, Cloud::Lattice}) {
    Bounds3 b;
    std::vector<Photon> photons = make_cloud(kind, 20000, 300 + int(kind), b);
    PhotonKdTree tree;
    tree.build(photons);
    std::vector<Vec3f> queries = make_queries(kind, photons, b, 200, 29 + int(kind));
    for (size_t k : {size_t(1), size_t(7), size_t(50), size_t(300)}) {
      for (float max_r : {kInf, 0.1f, 0.5f}) {
        idx.assign(k, 0);
        d2.assign(k, 0.f);
        for (size_t qi = 0; qi < queries.size(); ++qi) {
          Vec3f p = queries[qi];
          size_t n = tree.knn(p, k, max_r, idx.data(), d2.data());
          // Brute force: the k smallest (dist2, index) pairs within max_r (ties broken by lower index).
          all.clear();
          for (uint32_t i = 0; i < photons.size(); ++i) {
            float d = photon_dist2(p, photons[i].p);
            if (d <= max_r * max_r) all.push_back({d, i});
          }
          size_t m = std::min(k, all.size());
          // One more than k sorted, to see whether the (k+1)-th ties with the k-th.
          std::partial_sort(all.begin(), all.begin() + std::min(k + 1, all.size()), all.end());
          ASSERT_EQ(n, m) << cloud_name(kind) << " k " << k << " max_r " << max_r << " query " << qi;
          for (size_t j = 0; j < m; ++j) {
            ASSERT_EQ(idx[j], all[j].second) << cloud_name(kind) << " k " << k << " rank " << j << " query " << qi;
            ASSERT_EQ(d2[j], all[j].first);
          }
          if (m > 0 && m < all.size() && all[m].first == all[m - 1].first) ++ties_at_kth;
        }
      }
    }
  }
  std::printf("[ measured ] %zu kNN queries had a tie at the k-th distance\n", ties_at_kth);
  EXPECT_GT(ties_at_kth, 100u);  // the tie-breaking was exercised (lattice and duplicates)
}

// The portable tree (knn_tree.h: heap layout, host/device query) gives exactly PhotonKdTree's answers: the
// same brute force, on the same clouds (lattices and duplicate points make ties at the k-th distance), every
// size from 0 to 40 (incomplete last levels of the heap), and a heap-ordered layout in which every left
// subtree lies on its node's lower side and every right subtree on its upper side.
TEST(PhotonKnnTree, KnnEqualsBruteForce) {
  std::vector<uint32_t> nodes;
  std::vector<float> d2;
  std::vector<std::pair<float, uint32_t>> all;
  size_t ties_at_kth = 0, queries_done = 0;
  auto check = [&](const std::vector<Photon>& photons, const std::vector<Vec3f>& queries, const char* what) {
    const KnnTreeHost tree = build_knn_tree(photons);
    const KnnTreeView v = tree.view();
    ASSERT_EQ(v.n, photons.size());
    // Each node splits its subtrees: descendants on the left have coordinate <= its own, on the right >=.
    auto subtree_on_side = [&](uint32_t root, int a, float split, bool lower) {
      std::vector<uint32_t> pending{root};
      while (!pending.empty()) {
        const uint32_t j = pending.back();
        pending.pop_back();
        if (j >= v.n) continue;
        const float c = v.photons[j].p[a];
        if (lower ? c > split : c < split) return false;
        pending.push_back(2 * j + 1);
        pending.push_back(2 * j + 2);
      }
      return true;
    };
    for (uint32_t i = 0; i < v.n; ++i) {
      const int a = v.axis[i];
      const float split = v.photons[i].p[a];
      ASSERT_TRUE(subtree_on_side(2 * i + 1, a, split, true)) << what << " node " << i;
      ASSERT_TRUE(subtree_on_side(2 * i + 2, a, split, false)) << what << " node " << i;
      ASSERT_EQ(bits_of(v.photons[i]), bits_of(photons[v.index[i]]));
    }
    for (uint32_t k : {1u, 7u, 50u, 300u}) {
      for (float max_r : {kInf, 0.1f, 0.5f}) {
        nodes.assign(k, 0);
        d2.assign(k, 0.f);
        for (size_t qi = 0; qi < queries.size(); ++qi) {
          const Vec3f p = queries[qi];
          const uint32_t n = v.knn(p, k, max_r, nodes.data(), d2.data());
          all.clear();
          for (uint32_t i = 0; i < photons.size(); ++i) {
            float d = photon_dist2(p, photons[i].p);
            if (d <= max_r * max_r) all.push_back({d, i});
          }
          const size_t m = std::min(size_t(k), all.size());
          std::partial_sort(all.begin(), all.begin() + std::min(size_t(k) + 1, all.size()), all.end());
          ASSERT_EQ(n, m) << what << " k " << k << " max_r " << max_r << " query " << qi;
          for (size_t j = 0; j < m; ++j) {
            ASSERT_EQ(v.index[nodes[j]], all[j].second) << what << " k " << k << " rank " << j << " query " << qi;
            ASSERT_EQ(d2[j], all[j].first);
          }
          if (m > 0 && m < all.size() && all[m].first == all[m - 1].first) ++ties_at_kth;
          ++queries_done;
        }
      }
    }
  };
  for (Cloud kind : {Cloud::Uniform, Cloud::Clustered, Cloud::Planes, Cloud::Lattice}) {
    Bounds3 b;
    std::vector<Photon> photons = make_cloud(kind, 20000, 300 + int(kind), b);
    check(photons, make_queries(kind, photons, b, 100, 29 + int(kind)), cloud_name(kind));
  }
  for (size_t size = 0; size <= 40; ++size) {
    Bounds3 b;
    std::vector<Photon> photons = make_cloud(Cloud::Lattice, 40, 77, b);
    photons.resize(size);
    std::vector<Vec3f> queries{Vec3f(0.f), Vec3f(0.3f, 0.6f, 0.2f), Vec3f(2.f, -1.f, 0.5f)};
    check(photons, queries, "small");
  }
  std::printf("[ measured ] %zu portable kNN queries, %zu with a tie at the k-th distance\n", queries_done, ties_at_kth);
  EXPECT_GT(ties_at_kth, 100u);  // the tie-breaking was exercised (lattice and duplicates)
}

TEST(PhotonKdTree, EmptyTree) {
  PhotonKdTree tree;
  tree.build({});
  uint32_t i;
  float d;
  EXPECT_EQ(tree.knn(Vec3f(0.f), 3, kInf, &i, &d), 0u);
  std::vector<uint32_t> out{1, 2};
  tree.range(Vec3f(0.f), 1.f, out);
  EXPECT_TRUE(out.empty());
}
