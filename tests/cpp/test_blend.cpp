// Blends (Material::mix_a / mix_b, scene/interaction.h): resolve_material (in make_surface_hit) picks one of the
// two materials per point by a hash of the point, so the shares over a surface follow the weight (constant,
// textured, nested), a point always shows the same material, and Scene::build refuses cycles and dangling
// indices; and a pair of sides by the ray's side.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "caustica/backend/cpu/cpu_accel.h"
#include "caustica/base/error.h"
#include "caustica/base/rng.h"
#include "caustica/scene/scene.h"
#include "caustica/material/bsdf.h"
#include "caustica/scene/shading.h"

using namespace caustica;

namespace {

Material grey(float r) {
  Material m;
  m.type = MaterialType::kDiffuse;
  m.diffuse = RGB(r);
  return m;
}

Material blend(int a, int b, float w) {
  Material m;
  m.mix_a = a;
  m.mix_b = b;
  m.mix_weight = w;
  return m;
}

// The unit square at z = 0 (uv = xy) with material `material`, and a point light.
SceneDesc square(std::vector<Material> mats, int material) {
  SceneDesc d;
  d.materials = std::move(mats);
  MeshDesc m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  m.indices = {0, 1, 2, 0, 2, 3};
  d.meshes.push_back(m);
  ShapeDesc s;
  s.mesh = 0;
  s.material = material;
  d.shapes.push_back(s);
  d.lights.push_back(Light{});
  return d;
}

// The diffuse value surface_material gives at n random points (x, y), counted by value; `region` splits
// the count at x = 1/2 when it is set.
struct Shares {
  int n = 0, n_left = 0;
  std::map<float, int> all, left;
};
Shares shares(const Scene& sc, int n, uint64_t seed) {
  const SceneView& v = sc.view();
  PCG32 rng(seed, 3);
  Shares r;
  for (int i = 0; i < n; ++i) {
    Ray ray{Vec3f(rng.next_float(), rng.next_float(), 1.f), Vec3f(0, 0, -1), kInf};
    Hit h;
    EXPECT_TRUE(sc.cpu_accel("embree").intersect(ray, h));
    SurfaceHit sh = make_surface_hit(v, ray, h);
    Material m = surface_material(v, sh);
    EXPECT_LT(m.mix_b, 0);  // resolved
    // The same point gives the same material.
    SurfaceHit again = make_surface_hit(v, ray, h);
    EXPECT_EQ(surface_material(v, again).diffuse.x, m.diffuse.x);
    ++r.n;
    ++r.all[m.diffuse.x];
    if (sh.p.x < 0.5f) {
      ++r.n_left;
      ++r.left[m.diffuse.x];
    }
  }
  return r;
}

double binomial_se(double p, int n) { return std::sqrt(p * (1 - p) / n); }

}  // namespace

TEST(Blend, SharesFollowTheWeight) {
  auto sc = Scene::build(square({grey(0.2f), grey(0.8f), blend(0, 1, 0.25f)}, 2));
  const int n = 40000;
  Shares s = shares(*sc, n, 1);
  ASSERT_EQ(s.all.size(), 2u);
  EXPECT_NEAR(double(s.all[0.8f]) / n, 0.25, 4 * binomial_se(0.25, n));  // SE 0.0022
}

TEST(Blend, NestedBlendsMultiplyTheirWeights) {
  // blend(0.2, blend(0.5, 0.8; 0.4); 0.5): shares 0.5, 0.3, 0.2.
  auto sc = Scene::build(square({grey(0.2f), grey(0.5f), grey(0.8f), blend(1, 2, 0.4f), blend(0, 3, 0.5f)}, 4));
  const int n = 40000;
  Shares s = shares(*sc, n, 2);
  EXPECT_NEAR(double(s.all[0.2f]) / n, 0.5, 4 * binomial_se(0.5, n));
  EXPECT_NEAR(double(s.all[0.5f]) / n, 0.3, 4 * binomial_se(0.3, n));
  EXPECT_NEAR(double(s.all[0.8f]) / n, 0.2, 4 * binomial_se(0.2, n));
}

TEST(Blend, TextureWeightIsItsLuminanceTimesTheWeight) {
  // A 2 x 1 nearest texture: luminance 1 on the left half, 0.5 on the right (grey); weight 0.6: shares of the
  // second material 0.6 and 0.3.
  SceneDesc d = square({grey(0.2f), grey(0.8f), blend(0, 1, 0.6f)}, 2);
  TextureDesc t;
  t.name = "w";
  t.width = 2;
  t.height = 1;
  t.nearest = true;
  t.rgba = {1.f, 1.f, 1.f, 1.f, 0.5f, 0.5f, 0.5f, 1.f};
  d.textures.push_back(t);
  d.materials[2].tex_mix = 0;
  auto sc = Scene::build(d);
  const int n = 40000;
  Shares s = shares(*sc, n, 3);
  const int right = s.n - s.n_left;
  EXPECT_NEAR(double(s.left[0.8f]) / s.n_left, 0.6, 4 * binomial_se(0.6, s.n_left));
  EXPECT_NEAR(double(s.all[0.8f] - s.left[0.8f]) / right, 0.3, 4 * binomial_se(0.3, right));
}

TEST(Blend, SceneRefusesCyclesAndMissingMaterials) {
  EXPECT_THROW(Scene::build(square({grey(0.2f), blend(0, 1, 0.5f)}, 1)), InputError);            // contains itself
  EXPECT_THROW(Scene::build(square({blend(2, 1, 0.5f), blend(0, 2, 0.5f), grey(0.1f)}, 1)), InputError);  // 0 <-> 1
  EXPECT_THROW(Scene::build(square({grey(0.2f), blend(0, 7, 0.5f)}, 1)), InputError);            // no material 7
  EXPECT_THROW(Scene::build(square({grey(0.2f), blend(0, 0, 1.5f)}, 1)), InputError);            // weight > 1
  // Nine blends deep is more than resolve_material resolves.
  std::vector<Material> chain{grey(0.2f)};
  for (int i = 0; i < 9; ++i) chain.push_back(blend(0, int(chain.size()) - 1, 0.5f));
  EXPECT_THROW(Scene::build(square(chain, int(chain.size()) - 1)), InputError);
  chain.pop_back();
  EXPECT_NO_THROW(Scene::build(square(chain, int(chain.size()) - 1)));
}

// A pair of sides (kSides): make_surface_hit resolves it by the ray's side of the geometric normal (+z here),
// the back's material made two-sided by Scene::build (a copy: the front and the description keep theirs), a
// blend behind it resolved after the side; transmissive or null sides are refused.
TEST(Blend, PairOfSidesResolvesByTheRaysSide) {
  Material pair = blend(0, 2, 0.f);
  pair.flags = kSides;
  auto sc = Scene::build(square({grey(0.2f), grey(0.5f), blend(1, 1, 0.5f), pair}, 3));
  const SceneView& v = sc->view();
  for (int side : {1, -1}) {
    Ray ray{Vec3f(0.3f, 0.6f, float(side)), Vec3f(0, 0, float(-side)), kInf};
    Hit h;
    ASSERT_TRUE(sc->cpu_accel("embree").intersect(ray, h));
    SurfaceHit sh = make_surface_hit(v, ray, h);
    const Material m = surface_material(v, sh);
    EXPECT_LT(m.mix_b, 0);
    EXPECT_EQ(m.diffuse.x, side > 0 ? 0.2f : 0.5f) << side;
    EXPECT_EQ(bool(m.flags & kTwoSided), side < 0) << side;  // the back evaluated as if from its front
    // The back's diffuse is seen from behind: f = albedo / pi there, as from the front.
    const Vec3f wo(0.f, 0.f, float(side)), wi = normalize(Vec3f(0.3f, 0.f, float(side)));
    EXPECT_NEAR(bsdf_eval(m, wo, wi).x, m.diffuse.x / kPi, 1e-6f) << side;
  }
  EXPECT_EQ(v.materials[0].flags & kTwoSided, 0u);  // the front material itself is untouched
  Material glass;
  glass.type = MaterialType::kDielectric;
  Material glass_back = blend(0, 1, 0.f);
  glass_back.flags = kSides;
  EXPECT_THROW(Scene::build(square({grey(0.2f), glass, glass_back}, 2)), InputError);
}
