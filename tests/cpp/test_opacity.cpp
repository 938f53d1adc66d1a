// Cut-outs (scene/opacity.h): the ray queries skip candidate hits that a material's opacity removes, in
// Embree's filter functions and in the portable BVH alike; stochastic opacity passes the expected fraction
// of rays, independently per surface; an alpha test cuts a texture's shape out exactly; a sphere whose near
// crossing is cut out is hit at its far one; light samples on an emitter with opacity carry its coverage.
#include <gtest/gtest.h>

#include <cmath>

#include "caustica/backend/cpu/cpu_accel.h"
#include "caustica/base/error.h"
#include "caustica/base/rng.h"
#include "caustica/light/light_emit.h"
#include "caustica/light/light_sample.h"
#include "caustica/scene/intersect.h"
#include "caustica/scene/scene.h"

using namespace caustica;

namespace {

Material opaque_diffuse() {
  Material m;
  m.type = MaterialType::kDiffuse;
  return m;
}

// The square [0, 1]^2 at height z (two triangles, uv = xy), facing +z.
void add_square(SceneDesc& d, int material, float z, float scale = 1.f) {
  MeshDesc m;
  m.positions = {{0, 0, 0}, {scale, 0, 0}, {scale, scale, 0}, {0, scale, 0}};
  m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  m.indices = {0, 1, 2, 0, 2, 3};
  d.meshes.push_back(m);
  ShapeDesc s;
  s.mesh = int(d.meshes.size()) - 1;
  s.material = material;
  s.to_world.m[2][3] = z;
  d.shapes.push_back(s);
}

// One diffuse square of the given opacity (stochastic) at z = 0 and a point light.
SceneDesc square_scene(float opacity) {
  SceneDesc d;
  Material m = opaque_diffuse();
  m.opacity = opacity;
  d.materials = {m};
  add_square(d, 0, 0.f);
  d.lights.push_back(Light{});
  return d;
}

// A 2 x 2 texture, nearest lookups; alpha (or grey, for luminance) per texel, row 0 at the top (v = 1).
TextureDesc two_by_two(const float a[4], bool grey) {
  TextureDesc t;
  t.name = "mask";
  t.width = t.height = 2;
  t.nearest = true;
  for (int i = 0; i < 4; ++i) {
    float c = grey ? a[i] : 0.5f;
    t.rgba.insert(t.rgba.end(), {c, c, c, grey ? 1.f : a[i]});
  }
  return t;
}

// Vertical rays down onto (x, y) from z = 2, for random (x, y) in [0, 1]^2.
std::vector<Ray> rays_down(int n, uint64_t seed) {
  PCG32 rng(seed, 7);
  std::vector<Ray> r(n);
  for (Ray& x : r) {
    float px = rng.next_float(), py = rng.next_float();
    x = Ray{Vec3f(px, py, 2.f), normalize(Vec3f(0.01f * (rng.next_float() - 0.5f), 0.f, -1.f)), kInf};
  }
  return r;
}

}  // namespace

TEST(Opacity, StochasticOpacityPassesTheExpectedFractionInEmbreeAndThePortableBVH) {
  auto sc = Scene::build(square_scene(0.3f));
  ASSERT_TRUE(sc->view().alpha_tested);
  const CpuAccel& embree = sc->embree();
  ASSERT_EQ(embree.kind(), CpuAccel::Kind::kEmbree);
  BVHAccel bvh{&sc->view()};
  const int n = 40000;
  int hits = 0;
  for (const Ray& r : rays_down(n, 1)) {
    Hit he, hb;
    bool e = embree.intersect(r, he), b = bvh.intersect(r, hb);
    // The decision is a hash of the ray and the primitive: both queries, closest and any hit, agree.
    ASSERT_EQ(e, b);
    ASSERT_EQ(e, embree.occluded(r));
    ASSERT_EQ(e, bvh.occluded(r));
    hits += e;
  }
  // Binomial: SE = sqrt(0.3 * 0.7 / n) = 0.0023; 4 SE.
  EXPECT_NEAR(double(hits) / n, 0.3, 4 * std::sqrt(0.3 * 0.7 / n));
}

TEST(Opacity, StackedSurfacesDecideIndependently) {
  // Two squares of opacity 0.5 one above the other: a ray crosses both with probability 0.25 (a hash of the
  // ray alone would make them pass or block together: 0.5).
  SceneDesc d = square_scene(0.5f);
  add_square(d, 0, 0.5f);
  auto sc = Scene::build(d);
  const int n = 40000;
  int through = 0, top = 0;
  for (const Ray& r : rays_down(n, 2)) {
    Hit h;
    bool hit = sc->embree().intersect(r, h);
    through += !hit;
    top += hit && h.t < 1.7f;  // the upper square is at distance ~1.5
    Hit hb;
    ASSERT_EQ(hit, BVHAccel{&sc->view()}.intersect(r, hb));
    if (hit) ASSERT_EQ(h.prim, hb.prim);
  }
  EXPECT_NEAR(double(through) / n, 0.25, 4 * std::sqrt(0.25 * 0.75 / n));  // SE 0.0022
  EXPECT_NEAR(double(top) / n, 0.5, 4 * std::sqrt(0.25 / n));
}

TEST(Opacity, AlphaTestCutsTheTextureOut) {
  // Texels (top row first) 1 0 / 0 1 under a cutoff of 0.5: rays through the cut quadrants reach the floor
  // below; the same from the alpha channel and from the luminance.
  const float a[4] = {1.f, 0.f, 0.f, 1.f};
  for (bool grey : {false, true}) {
    SceneDesc d;
    d.textures.push_back(two_by_two(a, grey));
    Material m = opaque_diffuse();
    m.tex_opacity = 0;
    m.opacity_cutoff = 0.5f;
    if (grey) m.flags |= kOpacityLuminance;
    d.materials = {m, opaque_diffuse()};
    add_square(d, 0, 0.f);
    add_square(d, 1, -1.f);  // the floor: triangles 2 and 3
    d.lights.push_back(Light{});
    auto sc = Scene::build(d);
    BVHAccel bvh{&sc->view()};
    int n = 0;
    for (const Ray& r : rays_down(4000, 3)) {
      float x = r.o.x + r.d.x * 2.f / -r.d.z, y = r.o.y;
      if (std::fabs(x - 0.5f) < 0.01f || std::fabs(y - 0.5f) < 0.01f || x < 0.01f || x > 0.99f) continue;
      bool solid = (x < 0.5f) == (y > 0.5f);  // top-left and bottom-right texels are opaque
      Hit he, hb;
      ASSERT_TRUE(sc->embree().intersect(r, he));
      ASSERT_TRUE(bvh.intersect(r, hb));
      EXPECT_EQ(he.prim < 2, solid) << "grey " << grey << " at " << x << ", " << y;
      EXPECT_EQ(hb.prim < 2, solid) << "grey " << grey << " at " << x << ", " << y;
      ++n;
    }
    EXPECT_GT(n, 3000);
  }
}

TEST(Opacity, SphereWithItsNearCrossingCutOutIsHitAtTheFarOne) {
  // The sphere's texture is cut out on its upper half (v > 1/2 is the +z hemisphere): a ray straight down
  // through the centre skips the top and hits the bottom from inside; one from below hits the bottom.
  const float a[4] = {0.f, 0.f, 1.f, 1.f};  // top row (v > 1/2) cut
  SceneDesc d;
  d.textures.push_back(two_by_two(a, false));
  Material m = opaque_diffuse();
  m.tex_opacity = 0;
  m.opacity_cutoff = 0.5f;
  d.materials = {m};
  ShapeDesc s;
  s.type = ShapeType::kSphere;
  s.radius = 1.f;
  d.shapes.push_back(s);
  d.lights.push_back(Light{});
  auto sc = Scene::build(d);
  BVHAccel bvh{&sc->view()};
  Ray down{Vec3f(0.1f, 0.2f, 3.f), Vec3f(0, 0, -1), kInf};
  Ray up{Vec3f(0.1f, 0.2f, -3.f), Vec3f(0, 0, 1), kInf};
  const float t_far = 3.f + std::sqrt(1.f - 0.05f);
  const float t_near = 3.f - std::sqrt(1.f - 0.05f);
  for (const CpuAccel* acc : {&sc->embree()}) {
    Hit h;
    ASSERT_TRUE(acc->intersect(down, h));
    EXPECT_NEAR(h.t, t_far, 1e-4f);
    ASSERT_TRUE(acc->intersect(up, h));
    EXPECT_NEAR(h.t, t_near, 1e-4f);
    EXPECT_TRUE(acc->occluded(down));
  }
  Hit h;
  ASSERT_TRUE(bvh.intersect(down, h));
  EXPECT_NEAR(h.t, t_far, 1e-4f);
  ASSERT_TRUE(bvh.intersect(up, h));
  EXPECT_NEAR(h.t, t_near, 1e-4f);
  // A segment that ends before the far crossing is not blocked.
  Ray short_down = down;
  short_down.tmax = 3.5f;
  EXPECT_FALSE(sc->embree().occluded(short_down));
  EXPECT_FALSE(bvh.occluded(short_down));
  // From inside, upwards: the top is cut, nothing else is there.
  Ray inside_up{Vec3f(0.f, 0.f, 0.f), Vec3f(0, 0, 1), kInf};
  EXPECT_FALSE(sc->embree().intersect(inside_up, h));
  EXPECT_FALSE(bvh.intersect(inside_up, h));
}

TEST(Opacity, LightSamplesCarryTheCoverage) {
  // An emitting square of opacity 0.25 (stochastic): next-event and emission samples carry L x 0.25, what
  // rays that reach it see on average. Under an alpha test the cut parts emit nothing.
  for (bool test : {false, true}) {
    SceneDesc d;
    Material m = opaque_diffuse();
    m.opacity = 0.25f;
    if (test) m.opacity_cutoff = 0.5f;
    d.materials = {m};
    add_square(d, 0, 0.f);
    d.shapes.back().emission = RGB(2.f);
    auto sc = Scene::build(d);
    const SceneView& v = sc->view();
    ASSERT_EQ(v.num_lights, 2u);  // a light per triangle, each of area 1/2
    const float expect = test ? 0.f : 0.5f;
    LightSample ls;
    bool ok = sample_light(v, v.lights[0], Vec3f(0.5f, 0.5f, 1.f), Vec2f(0.3f, 0.4f), ls);
    EXPECT_EQ(ok, !test);
    if (ok) EXPECT_FLOAT_EQ(ls.Li.x, expect);
    EmitSample e;
    ok = sample_emission(v, v.lights[0], Vec2f(0.3f, 0.4f), Vec2f(0.5f, 0.5f), 0.f, e);
    EXPECT_EQ(ok, !test);
    if (ok) EXPECT_FLOAT_EQ(e.weight.x, expect * kPi * 0.5f);  // Le pi A
  }
}

TEST(Opacity, SceneChecksAndTheSmallSceneTest) {
  SceneDesc d = square_scene(1.5f);
  EXPECT_THROW(Scene::build(d), InputError);
  d.materials[0].opacity = 0.5f;
  auto sc = Scene::build(d);
  // The eight-wide small-scene test has no cut-outs: a scene with them goes to Embree, and asking for it
  // says why.
  EXPECT_FALSE(CpuAccel::small_suits(sc->view()));
  EXPECT_EQ(sc->cpu_accel("auto").kind(), CpuAccel::Kind::kEmbree);
  try {
    sc->cpu_accel("small");
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cut-outs"), std::string::npos) << e.what();
  }
  // Opaque materials leave the queries untouched.
  d.materials[0].opacity = 1.f;
  EXPECT_FALSE(Scene::build(d)->view().alpha_tested);
}
