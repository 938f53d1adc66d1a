// The lane-parallel path driver (integrator/path_lanes.h) against the scalar stages of path.h: for every
// pixel and sample index, the same radiance bit for bit, the same filter weight and the same number of
// ray queries. Exact equality is the claim path_lanes.h makes (the same IEEE operations in the same
// order, no contraction), so any difference, however small, fails.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "caustica/backend/cpu/cpu_accel.h"
#include "caustica/integrator/path_lanes.h"
#include "caustica/scene/builtin/builtin.h"
#include "caustica/scene/scene.h"

using namespace caustica;

namespace {

struct Mismatch {
  int pixels_compared = 0;
  int differing = 0;
  std::string first;
};

// Renders sample indices [0, passes) of every pixel both ways and compares. The lanes get the image in
// tiles of 13 x 7 pixels (partial tiles at the right and bottom edges), as render.cpp hands them its tiles.
template <typename Accel>
Mismatch compare(const SceneView& s, const Accel& accel, const PathParams& pp, int passes, uint64_t& rays_scalar,
                 uint64_t& rays_lanes) {
  Mismatch m;
  const int W = s.camera.width, H = s.camera.height, TW = 13, TH = 7;
  rays_scalar = rays_lanes = 0;
  std::vector<LaneResult> res(TW * TH);
  for (int pass = 0; pass < passes; ++pass) {
    for (int y0 = 0; y0 < H; y0 += TH) {
      for (int x0 = 0; x0 < W; x0 += TW) {
        const int w = std::min(TW, W - x0), h = std::min(TH, H - y0);
        LaneCounts counts;
        path_lanes_trace(s, accel, pp, uint32_t(x0), uint32_t(y0), w, h, uint32_t(pass), res.data(), counts);
        rays_lanes += counts.rays + counts.shadow_rays;
        for (int k = 0; k < w * h; ++k) {
          const int x = x0 + k % w, y = y0 + k / w;
          PathState st;
          path_trace(s, pp, accel, uint32_t(x), uint32_t(y), uint32_t(pass), st, rays_scalar, rays_scalar);
          ++m.pixels_compared;
          bool same = std::memcmp(&st.L, &res[k].L, sizeof(RGB)) == 0 &&
                      std::memcmp(&st.weight, &res[k].weight, sizeof(float)) == 0 && st.pixel == res[k].pixel;
          if (!same) {
            if (m.differing == 0) {
              char buf[256];
              std::snprintf(buf, sizeof buf, "pixel (%d, %d) pass %d: scalar (%.9g, %.9g, %.9g) w %.9g, lanes (%.9g, %.9g, %.9g) w %.9g",
                            x, y, pass, st.L.x, st.L.y, st.L.z, st.weight, res[k].L.x, res[k].L.y,
                            res[k].L.z, res[k].weight);
              m.first = buf;
            }
            ++m.differing;
          }
        }
      }
    }
  }
  return m;
}

// Mitsuba's Cornell box at a width that is not a multiple of the lane count (a partial group per row).
SceneDesc small_cornell(int w, int h) {
  SceneDesc d = builtin_scene("cornell");
  d.camera.width = w;
  d.camera.height = h;
  return d;
}

// The same box with what else the lanes cover: two-sided materials (bsdf_side's flip, seen through the
// open front's back faces), a diffuse sphere (make_surface_hit's sphere branch), a mesh with per-vertex
// normals (shading normals unlike the geometric ones), a two-sided emissive triangle, a thin-lens camera
// (the lens sample's dimensions), and materials whose vertices run the scalar stages in their lanes.
SceneDesc varied_cornell() {
  SceneDesc d = small_cornell(41, 33);
  for (Material& m : d.materials) m.flags |= kTwoSided;
  int white = d.add_material("ball", make_diffuse(RGB(0.6f, 0.5f, 0.4f)));
  ShapeDesc ball;
  ball.type = ShapeType::kSphere;
  ball.center = Vec3f(0.45f, -0.7f, 0.45f);
  ball.radius = 0.25f;
  ball.material = white;
  d.shapes.push_back(ball);
  // Materials the lanes hand to the scalar stages: glass with absorption, a rough conductor, a textured
  // diffuse (a 2x2 checker), each on a small sphere.
  Material glass = make_dielectric(1.5f);
  glass.absorption = RGB(0.5f, 0.2f, 0.1f);
  TextureDesc checker;
  checker.name = "checker";
  checker.width = checker.height = 2;
  checker.rgba = {0.9f, 0.9f, 0.9f, 1.f, 0.1f, 0.1f, 0.1f, 1.f, 0.1f, 0.1f, 0.1f, 1.f, 0.9f, 0.9f, 0.9f, 1.f};
  d.textures.push_back(checker);
  Material textured = make_diffuse(RGB(1.f));
  textured.tex_color = int(d.textures.size()) - 1;
  const Material others[3] = {glass, make_conductor(RGB(0.2f, 0.9f, 1.1f), RGB(3.9f, 2.4f, 2.2f), RGB(1.f), 0.2f),
                              textured};
  for (int k = 0; k < 3; ++k) {
    ShapeDesc b;
    b.type = ShapeType::kSphere;
    b.center = Vec3f(-0.6f + 0.6f * float(k), 0.3f, -0.3f);
    b.radius = 0.18f;
    b.material = d.add_material("other" + std::to_string(k), others[k]);
    d.shapes.push_back(b);
  }
  // An octahedron with vertex normals along the vertex directions (smooth shading of a coarse solid).
  MeshDesc oct;
  Vec3f c(-0.45f, -0.6f, 0.5f);
  const Vec3f dirs[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const Vec3f& v : dirs) {
    oct.positions.push_back(c + v * 0.3f);
    oct.normals.push_back(v);
  }
  const uint32_t faces[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (const auto& f : faces) oct.indices.insert(oct.indices.end(), {f[0], f[1], f[2]});
  d.meshes.push_back(oct);
  ShapeDesc octs;
  octs.type = ShapeType::kMesh;
  octs.mesh = int(d.meshes.size()) - 1;
  octs.material = white;
  d.shapes.push_back(octs);
  MeshDesc tri;
  tri.positions = {{-0.9f, 0.2f, -0.5f}, {-0.9f, 0.5f, -0.2f}, {-0.9f, 0.2f, 0.1f}};
  tri.indices = {0, 1, 2};
  d.meshes.push_back(tri);
  ShapeDesc lamp;
  lamp.type = ShapeType::kMesh;
  lamp.mesh = int(d.meshes.size()) - 1;
  lamp.material = white;
  lamp.emission = RGB(2.f, 3.f, 4.f);
  lamp.emission_two_sided = true;
  d.shapes.push_back(lamp);
  d.camera.aperture_radius = 0.05f;
  d.camera.focus_distance = 3.5f;
  return d;
}

}  // namespace

TEST(PathLanes, CoversDiffuseScenesAndSaysWhatOthersLack) {
  PathParams pp;
  std::shared_ptr<Scene> cornell = Scene::build(builtin_scene("cornell"));
  std::string why;
  EXPECT_TRUE(path_lanes_supported(cornell->view(), pp, &why)) << why;
  pp.sampler = SamplerType::kIndependent;  // both samplers run in lanes
  EXPECT_TRUE(path_lanes_supported(cornell->view(), pp, &why)) << why;
  pp.sampler = SamplerType::kSobol;
  // Mirror, glass and a glossy floor beside diffuse walls, a triangle light: covered (those vertices run
  // the scalar stages in their lanes).
  std::shared_ptr<Scene> spheres = Scene::build(builtin_scene("smallvcm-spheres"));
  EXPECT_TRUE(path_lanes_supported(spheres->view(), pp, &why)) << why;
  std::shared_ptr<Scene> sun = Scene::build(builtin_scene("smallvcm-sun"));
  EXPECT_FALSE(path_lanes_supported(sun->view(), pp, &why));
  EXPECT_EQ(why, "a light other than a triangle area light");
}

// Renders `passes` sample indices of the scene both ways and expects the same bits everywhere.
static void expect_bit_identical(const SceneDesc& d, const PathParams& pp, int passes) {
  std::shared_ptr<Scene> sc = Scene::build(d);
  std::string why;
  ASSERT_TRUE(path_lanes_supported(sc->view(), pp, &why)) << why;
  // Through Embree and through the scene's own choice (the small-scene test, where the CPU has AVX2).
  for (const CpuAccel* accel : {&sc->embree(), &sc->accel()}) {
    uint64_t rs, rl;
    Mismatch m = compare(sc->view(), *accel, pp, passes, rs, rl);
    EXPECT_EQ(m.differing, 0) << accel->name() << ": " << m.differing << " of " << m.pixels_compared
                              << " differ; first " << m.first;
    EXPECT_EQ(rs, rl);
    EXPECT_EQ(m.pixels_compared, d.camera.width * d.camera.height * passes);
  }
}

TEST(PathLanes, BitIdenticalToScalarStagesOnCornell) {
  if (!path_lanes_available()) GTEST_SKIP() << "this CPU has no AVX2: the lanes do not run here";
  PathParams pp;
  pp.max_depth = 8;
  pp.rr_depth = 5;
  pp.seed = 7;
  expect_bit_identical(small_cornell(44, 40), pp, 6);
}

// The independent sampler in lanes (eight PCG32 streams): the same bits as one path at a time, on cornell
// and with scalar vertices (mirror, glass, glossy floor) advancing their own streams.
TEST(PathLanes, BitIdenticalWithTheIndependentSampler) {
  if (!path_lanes_available()) GTEST_SKIP() << "this CPU has no AVX2: the lanes do not run here";
  PathParams pp;
  pp.sampler = SamplerType::kIndependent;
  pp.max_depth = 8;
  pp.rr_depth = 5;
  pp.seed = 5;
  expect_bit_identical(small_cornell(44, 40), pp, 4);
  SceneDesc d = builtin_scene("smallvcm-spheres");
  d.camera.width = 37;
  d.camera.height = 30;
  pp.max_depth = 12;
  pp.rr_depth = 3;
  expect_bit_identical(d, pp, 4);
}

TEST(PathLanes, BitIdenticalWithMirrorGlassAndGlossyVerticesInTheirLanes) {
  if (!path_lanes_available()) GTEST_SKIP() << "this CPU has no AVX2: the lanes do not run here";
  SceneDesc d = builtin_scene("smallvcm-spheres");
  d.camera.width = 37;
  d.camera.height = 30;
  PathParams pp;
  pp.seed = 11;
  pp.max_depth = 12;
  pp.rr_depth = 3;
  expect_bit_identical(d, pp, 5);
}

TEST(PathLanes, BitIdenticalOnTwoSidedSpheresShadingNormalsThinLensAndPortableBvh) {
  if (!path_lanes_available()) GTEST_SKIP() << "this CPU has no AVX2: the lanes do not run here";
  std::shared_ptr<Scene> sc = Scene::build(varied_cornell());
  const SceneView& v = sc->view();
  ASSERT_GT(v.num_spheres, 0u);
  ASSERT_NE(v.normals, nullptr);
  PathParams pp;
  pp.seed = 3;
  for (uint32_t rr : {2u, 5u}) {
    for (uint32_t max_depth : {3u, 0xffffffffu}) {
      pp.rr_depth = rr;
      pp.max_depth = max_depth;
      std::string why;
      ASSERT_TRUE(path_lanes_supported(v, pp, &why)) << why;
      for (const CpuAccel* accel : {&sc->embree(), &sc->accel()}) {
        uint64_t rs, rl;
        Mismatch m = compare(v, *accel, pp, 4, rs, rl);
        EXPECT_EQ(m.differing, 0) << accel->name() << " rr " << rr << " max_depth " << max_depth << ": "
                                  << m.differing << " of " << m.pixels_compared << " differ; first " << m.first;
        EXPECT_EQ(rs, rl);
      }
    }
  }
  BVHAccel bvh{&v};
  pp.rr_depth = 5;
  pp.max_depth = 8;
  uint64_t rs, rl;
  Mismatch m = compare(v, bvh, pp, 3, rs, rl);
  EXPECT_EQ(m.differing, 0) << m.differing << " of " << m.pixels_compared << " differ; first " << m.first;
  EXPECT_EQ(rs, rl);
}

// The light BVH (--light-sampler bvh) in lanes: each lane chooses its light from its own shading point, as
// path_shade does. Twelve small one-sided lamps facing every way make a BVH several levels deep, with
// points that some subtrees cannot light (importance 0).
TEST(PathLanes, BitIdenticalWithTheLightBvh) {
  if (!path_lanes_available()) GTEST_SKIP() << "this CPU has no AVX2: the lanes do not run here";
  SceneDesc d = varied_cornell();
  const int white = d.add_material("lamp", make_diffuse(RGB(0.5f)));
  for (int k = 0; k < 12; ++k) {
    const float a = 0.5236f * float(k);
    const Vec3f c(0.7f * std::cos(a), -0.2f + 0.05f * float(k % 4), 0.7f * std::sin(a));
    const Vec3f t(-std::sin(a), 0.f, std::cos(a));  // the lamp's plane holds t and the vertical
    MeshDesc m;
    const Vec3f up(0.f, 0.08f, 0.f);
    // Winding alternates so that half face the box's centre and half face the walls.
    if (k % 2) m.positions = {c - t * 0.08f, c + t * 0.08f, c + up};
    else m.positions = {c + t * 0.08f, c - t * 0.08f, c + up};
    m.indices = {0, 1, 2};
    d.meshes.push_back(m);
    ShapeDesc lamp;
    lamp.type = ShapeType::kMesh;
    lamp.mesh = int(d.meshes.size()) - 1;
    lamp.material = white;
    lamp.emission = RGB(1.f + float(k), 2.f, 8.f - 0.5f * float(k));
    d.shapes.push_back(lamp);
  }
  std::shared_ptr<Scene> sc = Scene::build(d);
  ASSERT_GE(sc->view().light_bvh.num_nodes, 7u);  // at least three levels
  PathParams pp;
  pp.light_bvh = true;
  pp.seed = 9;
  pp.max_depth = 8;
  pp.rr_depth = 3;
  expect_bit_identical(d, pp, 4);
  pp.sampler = SamplerType::kIndependent;
  expect_bit_identical(d, pp, 3);
}
