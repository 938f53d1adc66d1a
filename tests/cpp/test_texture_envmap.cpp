// Textures (lookup, wrapping, uv transform, normal maps), the importance-sampled
// environment map (chi-square of its sampling against its density, its
// orientation convention, its integral and photon power) and Beer-Lambert
// absorption in glass.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include "caustica/base/error.h"
#include "caustica/base/rng.h"
#include "caustica/film/image_io.h"
#include "caustica/integrator/render.h"
#include "caustica/light/light_emit.h"
#include "caustica/light/light_sample.h"
#include "caustica/material/bsdf.h"
#include "caustica/scene/intersect.h"
#include "caustica/scene/scene.h"
#include "caustica/scene/shading.h"
#include "chi2.h"

using namespace caustica;

namespace caustica {
bool operator==(const Vec3f& a, const Vec3f& b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
std::ostream& operator<<(std::ostream& o, const Vec3f& v) { return o << "(" << v.x << ", " << v.y << ", " << v.z << ")"; }
}  // namespace caustica

namespace {

TextureDesc make_texture(int w, int h, std::function<RGB(int, int)> f) {
  TextureDesc t;
  t.name = "test";
  t.width = w;
  t.height = h;
  t.rgba.resize(size_t(w) * h * 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      RGB c = f(x, y);
      float* p = &t.rgba[(size_t(y) * w + x) * 4];
      p[0] = c.x;
      p[1] = c.y;
      p[2] = c.z;
      p[3] = 1.f;
    }
  return t;
}

// Adds the unit square in z = 0 facing +z (corners (0,0), (1,0), (1,1), (0,1)) with these UVs (empty: none)
// as a shape of `material`, moved x along the x axis.
void add_unit_quad(SceneDesc& d, std::vector<Vec2f> uvs, int material, float x) {
  MeshDesc m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.uvs = std::move(uvs);
  m.indices = {0, 1, 2, 0, 2, 3};
  d.meshes.push_back(m);
  ShapeDesc s;
  s.mesh = int(d.meshes.size()) - 1;
  s.material = material;
  s.to_world.m[0][3] = x;
  d.shapes.push_back(s);
}

TextureView view_of(const TextureDesc& t) {
  TextureView v;
  v.rgba = t.rgba.data();
  v.width = t.width;
  v.height = t.height;
  v.wrap_u = t.wrap_u;
  v.wrap_v = t.wrap_v;
  v.nearest = t.nearest;
  return v;
}

// A small scene (one quad) whose only light is an environment map.
SceneDesc env_scene(const TextureDesc& tex, const Affine& to_world, RGB scale = RGB(1.f)) {
  SceneDesc d;
  d.name = "env";
  d.add_material("white", make_diffuse(RGB(0.5f)));
  ShapeDesc quad;
  quad.type = ShapeType::kRectangle;
  d.shapes.push_back(quad);
  d.textures.push_back(tex);
  Light env;
  env.type = LightType::kEnvironment;
  env.L = scale;
  env.texture = 0;
  d.lights.push_back(env);
  d.environment_to_world = to_world;
  return d;
}

Affine rotation_x(float deg) {
  float a = deg * kPi / 180.f, c = std::cos(a), s = std::sin(a);
  Affine r;
  r.m[1][1] = c;
  r.m[1][2] = -s;
  r.m[2][1] = s;
  r.m[2][2] = c;
  return r;
}

// A map with a bright "sun" texel, a gradient sky and a black row (zero density there).
TextureDesc sky_texture(bool nearest) {
  TextureDesc t = make_texture(16, 8, [](int x, int y) {
    if (x == 11 && y == 2) return RGB(200.f, 180.f, 150.f);
    if (y == 6) return RGB(0.f);
    return RGB(0.2f + 0.1f * y, 0.3f + 0.02f * x, 0.5f);
  });
  t.nearest = nearest;
  return t;
}

}  // namespace

TEST(Texture, NearestAndBilinearLookupsHitTexelValues) {
  // 2 x 2: top row (row 0) red, green; bottom row blue, white. v = 0 is the bottom.
  TextureDesc t = make_texture(2, 2, [](int x, int y) {
    const RGB c[2][2] = {{RGB(1, 0, 0), RGB(0, 1, 0)}, {RGB(0, 0, 1), RGB(1, 1, 1)}};
    return c[y][x];
  });
  TextureView v = view_of(t);
  // Texel centres: bilinear weights are exactly one there.
  EXPECT_EQ(texture_lookup(v, Vec2f(0.25f, 0.75f)).rgb(), RGB(1, 0, 0));  // top-left
  EXPECT_EQ(texture_lookup(v, Vec2f(0.75f, 0.75f)).rgb(), RGB(0, 1, 0));  // top-right
  EXPECT_EQ(texture_lookup(v, Vec2f(0.25f, 0.25f)).rgb(), RGB(0, 0, 1));  // bottom-left
  EXPECT_EQ(texture_lookup(v, Vec2f(0.75f, 0.25f)).rgb(), RGB(1, 1, 1));
  // The middle is the average of the four.
  RGB mid = texture_lookup(v, Vec2f(0.5f, 0.5f)).rgb();
  EXPECT_NEAR(mid.x, 0.5f, 1e-6f);
  EXPECT_NEAR(mid.y, 0.5f, 1e-6f);
  EXPECT_NEAR(mid.z, 0.5f, 1e-6f);
  // Repeat: u = 0 blends the left and right columns halfway.
  RGB edge = texture_lookup(v, Vec2f(0.f, 0.75f)).rgb();
  EXPECT_NEAR(edge.x, 0.5f, 1e-6f);
  EXPECT_NEAR(edge.y, 0.5f, 1e-6f);
  // Clamp: the edge is the edge texel.
  v.wrap_u = v.wrap_v = TexWrap::kClamp;
  EXPECT_EQ(texture_lookup(v, Vec2f(0.f, 0.75f)).rgb(), RGB(1, 0, 0));
  EXPECT_EQ(texture_lookup(v, Vec2f(-3.f, 0.75f)).rgb(), RGB(1, 0, 0));
  // Mirror: u in (1, 2) reads the image backwards, so 1.25 is the right column.
  v.wrap_u = v.wrap_v = TexWrap::kMirror;
  EXPECT_EQ(texture_lookup(v, Vec2f(1.25f, 0.75f)).rgb(), RGB(0, 1, 0));
  EXPECT_EQ(texture_lookup(v, Vec2f(1.75f, 0.75f)).rgb(), RGB(1, 0, 0));
  // Nearest: any point inside a texel returns it.
  // Each axis its own mode (glTF's wrapS and wrapT): repeat along u, clamp along v. Above the image (v 1.25)
  // v clamps to the top row while u 1.25 repeats to the left column: (1, 0, 0); u clamped instead reads the
  // right column, (0, 1, 0); and v repeated reads the bottom row, (0, 0, 1) and (1, 1, 1).
  v.wrap_u = TexWrap::kRepeat;
  v.wrap_v = TexWrap::kClamp;
  v.nearest = 1;
  EXPECT_EQ(texture_lookup(v, Vec2f(1.25f, 1.25f)).rgb(), RGB(1, 0, 0));
  v.wrap_u = TexWrap::kClamp;
  EXPECT_EQ(texture_lookup(v, Vec2f(1.25f, 1.25f)).rgb(), RGB(0, 1, 0));
  v.wrap_u = TexWrap::kRepeat;
  v.wrap_v = TexWrap::kRepeat;
  EXPECT_EQ(texture_lookup(v, Vec2f(1.25f, 1.25f)).rgb(), RGB(0, 0, 1));
  v.wrap_u = TexWrap::kClamp;
  EXPECT_EQ(texture_lookup(v, Vec2f(1.25f, 1.25f)).rgb(), RGB(1, 1, 1));
  v.wrap_u = TexWrap::kRepeat;
  EXPECT_EQ(texture_lookup(v, Vec2f(0.51f, 0.99f)).rgb(), RGB(0, 1, 0));
  EXPECT_EQ(texture_lookup(v, Vec2f(1.01f, 0.01f)).rgb(), RGB(0, 0, 1));  // wrapped
  // uv transform: offset 0.5 in u moves the right column to the left half.
  v.uv_offset = Vec2f(0.5f, 0.f);
  EXPECT_EQ(texture_lookup(v, Vec2f(0.25f, 0.75f)).rgb(), RGB(0, 1, 0));
  // Rotation by 90 degrees maps (u, v) to (-v, u): (0.25, 0.25) -> (-0.25, 0.25) = (0.75, 0.25).
  v.uv_offset = Vec2f(0.f, 0.f);
  v.cos_rot = 0.f;
  v.sin_rot = 1.f;
  EXPECT_EQ(texture_lookup(v, Vec2f(0.25f, 0.25f)).rgb(), RGB(1, 1, 1));
}

TEST(Texture, ColourRoughnessAndNormalMapsApplyAtTheHit) {
  SceneDesc d;
  d.name = "tex";
  // Texture 0: colour; 1: metallic-roughness (G = 0.5, B = 0.25); 2: flat normal; 3: tilted normal.
  d.textures.push_back(make_texture(1, 1, [](int, int) { return RGB(0.2f, 0.4f, 0.6f); }));
  d.textures.push_back(make_texture(1, 1, [](int, int) { return RGB(0.f, 0.5f, 0.25f); }));
  d.textures.push_back(make_texture(1, 1, [](int, int) { return RGB(0.5f, 0.5f, 1.f); }));
  d.textures.push_back(make_texture(1, 1, [](int, int) { return RGB(1.f, 0.5f, 1.f); }));  // (1, 0, 1) in tangent space
  Material mr = make_metallic_roughness(RGB(1.f, 0.5f, 1.f), 1.f, 0.8f);
  mr.tex_color = 0;
  mr.tex_roughness = 1;
  mr.tex_normal = 2;
  d.add_material("mr", mr);
  Material tilted = make_diffuse(RGB(1.f));
  tilted.tex_normal = 3;
  d.add_material("tilted", tilted);
  for (int i = 0; i < 2; ++i) add_unit_quad(d, {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, i, 3.f * i);  // u along +x, v +y
  d.lights.push_back(Light{});
  auto sc = Scene::build(d);
  const SceneView& v = sc->view();
  for (int i = 0; i < 2; ++i) {
    Ray r{Vec3f(3.f * i + 0.3f, 0.6f, 1.f), Vec3f(0, 0, -1), kInf};
    Hit h;
    ASSERT_TRUE(scene_intersect(v, r, h));
    SurfaceHit sh = make_surface_hit(v, r, h);
    EXPECT_NEAR(sh.uv.x, 0.3f, 1e-5f);
    EXPECT_NEAR(sh.uv.y, 0.6f, 1e-5f);
    Material m = surface_material(v, sh);
    if (i == 0) {
      EXPECT_NEAR(m.diffuse.x, 0.2f, 1e-6f);
      EXPECT_NEAR(m.diffuse.y, 0.2f, 1e-6f);  // 0.5 * 0.4
      EXPECT_NEAR(m.diffuse.z, 0.6f, 1e-6f);
      EXPECT_NEAR(m.alpha_x, std::pow(0.8f * 0.5f, 2.f), 1e-6f);  // (G * roughness)^2
      EXPECT_NEAR(m.metallic, 0.25f, 1e-6f);
      EXPECT_NEAR(sh.ns.z, 1.f, 1e-6f);  // the flat normal map leaves the normal alone
    } else {
      // (1, 0.5, 1) -> tangent-space (1, 0, 1): the normal tilts 45 degrees towards +x (dp/du).
      EXPECT_NEAR(sh.ns.x, std::sqrt(0.5f), 1e-5f);
      EXPECT_NEAR(sh.ns.y, 0.f, 1e-5f);
      EXPECT_NEAR(sh.ns.z, std::sqrt(0.5f), 1e-5f);
    }
  }
}

// Anisotropic roughness is measured along dp/du (pbrt-v4's uroughness, Mitsuba 3's alpha_u): the shading
// frame's first axis follows the texture parameterisation, not the normal alone.
TEST(Texture, AnisotropicShadingFrameFollowsDpDu) {
  SceneDesc d;
  d.name = "aniso";
  Material aniso = make_conductor(RGB(0.2f), RGB(3.f), RGB(1.f), 0.05f);
  aniso.alpha_y = 0.4f;
  d.add_material("aniso", aniso);
  d.add_material("iso", make_conductor(RGB(0.2f), RGB(3.f), RGB(1.f), 0.2f));
  // Quads in z = 0 facing +z: 0 with u along +x, 1 with u along +y (the UVs turned a quarter), 2 without
  // UVs, 3 = 0 with the isotropic material; each 3 units further along x.
  const std::vector<std::vector<Vec2f>> uvs = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}, {{0, 1}, {0, 0}, {1, 0}, {1, 1}}, {},
                                               {{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
  for (int i = 0; i < 4; ++i) add_unit_quad(d, uvs[i], i == 3 ? 1 : 0, 3.f * i);
  ShapeDesc sphere;
  sphere.type = ShapeType::kSphere;
  sphere.center = Vec3f(0.f, 0.f, -5.f);
  sphere.material = 0;
  d.shapes.push_back(sphere);
  d.lights.push_back(Light{});
  auto sc = Scene::build(d);
  const SceneView& v = sc->view();
  auto frame_at = [&](Vec3f o, Vec3f dir, SurfaceHit& sh) {
    Ray r{o, dir, kInf};
    Hit h;
    EXPECT_TRUE(scene_intersect(v, r, h));
    sh = make_surface_hit(v, r, h);
    Material m = surface_material(v, sh);
    return shading_frame(v, sh, m);
  };
  auto expect_orthonormal = [](const Frame& f) {
    EXPECT_NEAR(dot(f.s, f.t), 0.f, 1e-6f);
    EXPECT_NEAR(dot(f.s, f.n), 0.f, 1e-6f);
    EXPECT_NEAR(length(f.s), 1.f, 1e-6f);
    EXPECT_NEAR(length(f.t), 1.f, 1e-6f);
    EXPECT_NEAR(dot(cross(f.s, f.t), f.n), 1.f, 1e-6f);  // right-handed, as Frame(n)
  };
  SurfaceHit sh;
  Frame f = frame_at(Vec3f(0.3f, 0.6f, 1.f), Vec3f(0, 0, -1), sh);
  expect_orthonormal(f);
  EXPECT_NEAR(f.s.x, 1.f, 1e-6f);  // u along +x
  f = frame_at(Vec3f(3.3f, 0.6f, 1.f), Vec3f(0, 0, -1), sh);
  expect_orthonormal(f);
  EXPECT_NEAR(f.s.y, 1.f, 1e-6f);  // u runs along +y on the turned quad (u = y)
  // Without UVs and for isotropic materials: the normal's own frame, bit for bit (images of isotropic
  // materials do not change).
  for (float x : {6.3f, 9.3f}) {
    f = frame_at(Vec3f(x, 0.6f, 1.f), Vec3f(0, 0, -1), sh);
    Frame g(sh.ns);
    EXPECT_EQ(f.s, g.s);
    EXPECT_EQ(f.t, g.t);
  }
  // Sphere: u = phi / 2pi about +z, so s is the direction of increasing phi, (-n.y, n.x, 0) normalised.
  f = frame_at(Vec3f(3.f, 2.f, -4.5f), normalize(Vec3f(-3.f, -2.f, 0.f)), sh);
  expect_orthonormal(f);
  Vec3f want = normalize(Vec3f(-sh.ng.y, sh.ng.x, 0.f));
  EXPECT_NEAR(dot(f.s, want), 1.f, 1e-5f);
  // At the pole there is no phi direction: the normal's frame.
  Ray pole{Vec3f(0.f, 0.f, -2.f), Vec3f(0, 0, -1), kInf};
  Hit h;
  ASSERT_TRUE(scene_intersect(v, pole, h));
  sh = make_surface_hit(v, pole, h);
  f = shading_frame(v, sh, surface_material(v, sh));
  expect_orthonormal(f);
  // aniso_rotation turns the direction from dp/du towards dp/dv (counter-clockwise seen from the normal);
  // on a quad with mirrored UVs (v growing along -y) dp/dv points the other way, and so does the turn.
  {
    sh = SurfaceHit();
    Ray r{Vec3f(0.3f, 0.6f, 1.f), Vec3f(0, 0, -1), kInf};
    Hit hq;
    ASSERT_TRUE(scene_intersect(v, r, hq));
    sh = make_surface_hit(v, r, hq);
    Material m = surface_material(v, sh);
    m.aniso_rotation = kPi / 6.f;
    Frame fr = shading_frame(v, sh, m);
    expect_orthonormal(fr);
    EXPECT_NEAR(fr.s.x, std::cos(kPi / 6.f), 1e-6f);
    EXPECT_NEAR(fr.s.y, std::sin(kPi / 6.f), 1e-6f);  // towards dp/dv = +y
  }
  {
    SceneDesc dm;
    dm.add_material("aniso", aniso);
    add_unit_quad(dm, {{0, 1}, {1, 1}, {1, 0}, {0, 0}}, 0, 0.f);  // u along +x, v along -y: mirrored
    dm.lights.push_back(Light{});
    auto scm = Scene::build(dm);
    const SceneView& vm = scm->view();
    Ray r{Vec3f(0.3f, 0.6f, 1.f), Vec3f(0, 0, -1), kInf};
    Hit hq;
    ASSERT_TRUE(scene_intersect(vm, r, hq));
    SurfaceHit shm = make_surface_hit(vm, r, hq);
    Material mm = surface_material(vm, shm);
    mm.aniso_rotation = kPi / 6.f;
    Frame fr = shading_frame(vm, shm, mm);
    expect_orthonormal(fr);
    EXPECT_NEAR(fr.s.x, std::cos(kPi / 6.f), 1e-6f);
    EXPECT_NEAR(fr.s.y, -std::sin(kPi / 6.f), 1e-6f);  // towards dp/dv = -y
  }
  // Evaluated through the frames, the turned quad with swapped alphas is the same BSDF.
  Material swapped = aniso;
  std::swap(swapped.alpha_x, swapped.alpha_y);
  const Frame f0 = tangent_frame(Vec3f(0, 0, 1), Vec3f(1, 0, 0)), f1 = tangent_frame(Vec3f(0, 0, 1), Vec3f(0, 1, 0));
  const Vec3f wo = normalize(Vec3f(0.3f, -0.5f, 0.8f)), wi = normalize(Vec3f(-0.6f, 0.2f, 0.7f));
  RGB a = bsdf_eval(aniso, f0.to_local(wo), f0.to_local(wi)), b = bsdf_eval(swapped, f1.to_local(wo), f1.to_local(wi));
  RGB c = bsdf_eval(swapped, f0.to_local(wo), f0.to_local(wi));
  EXPECT_NEAR(a.x, b.x, 1e-5f * a.x);
  EXPECT_GT(std::fabs(a.x - c.x), 0.1f * a.x);  // and the frame does matter for it
}

// Vertex tangents (generate_tangents, JSON "tangents", glTF TANGENT): on a flat half-annulus of 8 facets with
// polar UVs (u along the arc, v outwards), the generated tangents are the circle's (the facets' chords,
// averaged), the anisotropic frame is continuous across an edge where the triangles' own dp/du jump by the
// facet angle, and mirroring transforms and flipped normals keep the axes along +u and +v.
TEST(Texture, VertexTangentsAreSmoothAndKeepHandedness) {
  const int kFacets = 8;
  MeshDesc ring;  // radii 1 and 2 in z = 0, a from 0 to pi; u = a / pi, v = r - 1
  for (int i = 0; i <= kFacets; ++i) {
    float a = kPi * float(i) / float(kFacets);
    for (int r = 1; r <= 2; ++r) {
      ring.positions.push_back(Vec3f(float(r) * std::cos(a), float(r) * std::sin(a), 0.f));
      ring.normals.push_back(Vec3f(0.f, 0.f, 1.f));
      ring.uvs.push_back(Vec2f(float(i) / float(kFacets), float(r - 1)));
    }
  }
  for (uint32_t i = 0; i < uint32_t(kFacets); ++i) {
    uint32_t a0 = 2 * i, a1 = 2 * i + 1, b0 = 2 * i + 2, b1 = 2 * i + 3;  // a: inner/outer at a_i, b: at a_i+1
    for (uint32_t k : {a0, b0, b1, a0, b1, a1}) ring.indices.push_back(k);  // counter-clockwise seen from +z
  }
  generate_tangents(ring);
  ASSERT_EQ(ring.tangents.size(), ring.positions.size());
  for (size_t k = 0; k < ring.positions.size(); ++k) {
    float a = kPi * float(k / 2) / float(kFacets);
    const Tangent& t = ring.tangents[k];
    ASSERT_EQ(t.w, -1.f) << k;  // cross(+z, tangent) points inwards, v outwards
    Vec3f b = cross(ring.normals[k], t.t) * t.w;
    Vec3f circle(-std::sin(a), std::cos(a), 0.f);
    if (k >= 2 && k < ring.positions.size() - 2) {  // interior vertices: the two chords' mean is the circle's tangent
      EXPECT_NEAR(dot(t.t, circle), 1.f, 1e-5f) << k;
      EXPECT_NEAR(dot(b, Vec3f(std::cos(a), std::sin(a), 0.f)), 1.f, 1e-5f) << k;
    } else {  // the ends have one facet: its chord
      EXPECT_NEAR(dot(t.t, circle), std::cos(0.5f * kPi / float(kFacets)), 1e-5f) << k;
    }
  }

  Material aniso = make_conductor(RGB(0.2f), RGB(3.f), RGB(1.f), 0.05f);
  aniso.alpha_y = 0.4f;
  // Shape 0: the ring; 1: mirrored in x (negative determinant); 2: flipped normals; 3: the ring without
  // tangents (the facets' dp/du). Each is moved 6 units along x.
  SceneDesc d;
  d.add_material("aniso", aniso);
  d.meshes.push_back(ring);
  MeshDesc bare = ring;
  bare.tangents.clear();
  d.meshes.push_back(bare);
  for (int k = 0; k < 4; ++k) {
    ShapeDesc s;
    s.mesh = k == 3 ? 1 : 0;
    if (k == 1) s.to_world.m[0][0] = -1.f;
    s.flip_normals = k == 2;
    s.to_world.m[0][3] = 6.f * float(k);
    d.shapes.push_back(s);
  }
  d.lights.push_back(Light{});
  auto sc = Scene::build(d);
  const SceneView& v = sc->view();
  ASSERT_NE(v.tangents, nullptr);
  auto hit_at = [&](int shape, float a, SurfaceHit& sh) {
    float sx = shape == 1 ? -1.f : 1.f;
    Ray r{Vec3f(6.f * float(shape) + sx * 1.5f * std::cos(a), 1.5f * std::sin(a), 1.f), Vec3f(0, 0, -1), kInf};
    Hit h;
    EXPECT_TRUE(scene_intersect(v, r, h));
    sh = make_surface_hit(v, r, h);
    return surface_material(v, sh);
  };
  const float edge = kPi * 3.f / float(kFacets), eps = 1e-3f;
  for (int shape = 0; shape < 4; ++shape) {
    SurfaceHit lo, hi;
    Material mlo = hit_at(shape, edge - eps, lo), mhi = hit_at(shape, edge + eps, hi);
    Frame flo = shading_frame(v, lo, mlo), fhi = shading_frame(v, hi, mhi);
    Vec3f tlo, blo, thi, bhi;
    ASSERT_TRUE(triangle_dpduv(v, lo.prim, tlo, blo));
    ASSERT_TRUE(triangle_dpduv(v, hi.prim, thi, bhi));
    float jump = std::acos(clampf(dot(normalize(tlo), normalize(thi)), -1.f, 1.f));
    EXPECT_NEAR(jump, kPi / float(kFacets), 1e-3f) << shape;  // the facets' own dp/du turn by the facet angle
    float turn = std::acos(clampf(dot(flo.s, fhi.s), -1.f, 1.f));
    if (shape == 3) {
      EXPECT_NEAR(turn, kPi / float(kFacets), 1e-3f) << shape;  // without tangents the frame jumps with them
      continue;
    }
    EXPECT_LT(turn, 0.01f) << shape;  // with them it is continuous (2 eps of arc = 0.002 rad; the jump is 0.39)
    // The interpolated axes point the way the transformed UVs grow, whatever the transform did.
    for (const SurfaceHit* sh : {&lo, &hi}) {
      Vec3f tu, tv, du, dv;
      ASSERT_TRUE(surface_uv_axes(v, *sh, tu, tv));
      ASSERT_TRUE(triangle_dpduv(v, sh->prim, du, dv));
      EXPECT_GT(dot(normalize(tu), normalize(du)), 0.95f) << shape;
      EXPECT_GT(dot(normalize(tv), normalize(dv)), 0.95f) << shape;
    }
  }

  // A mirrored seam: two quads share an edge, u growing towards it from both sides. Their vertices there get
  // w = 0, and each quad keeps its own dp/du.
  MeshDesc seam;
  seam.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 1, 0}};
  seam.normals.assign(6, Vec3f(0, 0, 1));
  seam.uvs = {{0, 0}, {1, 0}, {0, 0}, {0, 1}, {1, 1}, {0, 1}};
  seam.indices = {0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4};
  generate_tangents(seam);
  EXPECT_EQ(seam.tangents[1].w, 0.f);
  EXPECT_EQ(seam.tangents[4].w, 0.f);
  EXPECT_EQ(seam.tangents[0].w, 1.f);
  EXPECT_EQ(seam.tangents[2].w, -1.f);
  SceneDesc ds;
  ds.add_material("aniso", aniso);
  ds.meshes.push_back(seam);
  ShapeDesc q;
  q.mesh = 0;
  ds.shapes.push_back(q);
  ds.lights.push_back(Light{});
  auto scs = Scene::build(ds);
  for (float x : {0.5f, 1.5f}) {
    Ray r{Vec3f(x, 0.3f, 1.f), Vec3f(0, 0, -1), kInf};
    Hit h;
    ASSERT_TRUE(scene_intersect(scs->view(), r, h));
    SurfaceHit sh = make_surface_hit(scs->view(), r, h);
    Vec3f tu, tv;
    ASSERT_TRUE(surface_uv_axes(scs->view(), sh, tu, tv));
    EXPECT_NEAR(normalize(tu).x, x < 1.f ? 1.f : -1.f, 1e-6f) << x;
    EXPECT_NEAR(normalize(tv).y, 1.f, 1e-6f) << x;
  }
}

// A normal map's y axis on mirrored UVs (v growing along -y): turned to dp/dv's side by default (MikkTSpace,
// glTF), n x dp/du with kNormalMapCross (Mitsuba 3, pbrt-v4).
TEST(Texture, NormalMapBitangentOnMirroredUVs) {
  SceneDesc d;
  d.textures.push_back(make_texture(1, 1, [](int, int) { return RGB(0.5f, 1.f, 1.f); }));  // (0, 1, 1): towards +y
  for (int k = 0; k < 2; ++k) {
    Material m = make_diffuse(RGB(1.f));
    m.tex_normal = 0;
    if (k == 1) m.flags |= kNormalMapCross;
    d.add_material("m" + std::to_string(k), m);
    add_unit_quad(d, {{0, 1}, {1, 1}, {1, 0}, {0, 0}}, k, 3.f * float(k));  // u along +x, v along -y
  }
  d.lights.push_back(Light{});
  auto sc = Scene::build(d);
  for (int k = 0; k < 2; ++k) {
    Ray r{Vec3f(3.f * float(k) + 0.5f, 0.5f, 1.f), Vec3f(0, 0, -1), kInf};
    Hit h;
    ASSERT_TRUE(scene_intersect(sc->view(), r, h));
    SurfaceHit sh = make_surface_hit(sc->view(), r, h);
    surface_material(sc->view(), sh);
    EXPECT_NEAR(sh.ns.y, k == 0 ? -std::sqrt(0.5f) : std::sqrt(0.5f), 1e-5f) << k;  // dp/dv = -y; n x dp/du = +y
    EXPECT_NEAR(sh.ns.z, std::sqrt(0.5f), 1e-5f) << k;
  }
}

// A sphere's UVs are measured in its own frame (Mitsuba 3 and pbrt-v4 spheres use object space): turned a
// quarter about x (local +z to world -y), its +z pole, the top row of its texture, faces -y; its anisotropy
// direction (the longitude) and a normal map turn with it. Spheres take normal maps (longitude and latitude
// as tangent and bitangent).
TEST(Texture, RotatedSphereTurnsItsUVsAndFrame) {
  SceneDesc d;
  d.textures.push_back(make_texture(1, 1, [](int, int) { return RGB(0.5f, 1.f, 1.f); }));  // (0, 1, 1): towards +v
  Material aniso = make_conductor(RGB(0.2f), RGB(3.f), RGB(1.f), 0.05f);
  aniso.alpha_y = 0.4f;
  d.add_material("aniso", aniso);
  Material mapped = make_diffuse(RGB(1.f));
  mapped.tex_normal = 0;
  d.add_material("mapped", mapped);
  for (int k = 0; k < 3; ++k) {  // 0: turned, 1: unturned, 2: unturned with the normal map
    ShapeDesc sp;
    sp.type = ShapeType::kSphere;
    sp.material = k == 2 ? 1 : 0;
    if (k == 0) {  // rotation by +90 degrees about x, scaled by 2: (x, y, z) -> 2 (x, -z, y)
      sp.to_world.m[0][0] = 2.f;
      sp.to_world.m[1][1] = 0.f;
      sp.to_world.m[1][2] = -2.f;
      sp.to_world.m[2][1] = 2.f;
      sp.to_world.m[2][2] = 0.f;
    }
    sp.to_world.m[0][3] = 5.f * float(k);
    d.shapes.push_back(sp);
  }
  d.lights.push_back(Light{});
  auto sc = Scene::build(d);
  const SceneView& v = sc->view();
  ASSERT_NE(v.sphere_frames, nullptr);
  auto hit = [&](int k, Vec3f n, SurfaceHit& sh) {
    Vec3f c(5.f * float(k), 0.f, 0.f);
    Ray r{c + n * 4.f, -n, kInf};
    Hit h;
    EXPECT_TRUE(scene_intersect(v, r, h));
    sh = make_surface_hit(v, r, h);
    return surface_material(v, sh);
  };
  SurfaceHit sh;
  hit(0, Vec3f(0, -1, 0), sh);
  EXPECT_NEAR(sh.uv.y, 1.f, 1e-5f);  // the turned sphere's +z pole
  hit(1, Vec3f(0, -1, 0), sh);
  EXPECT_NEAR(sh.uv.y, 0.5f, 1e-5f);  // on the unturned one's equator
  EXPECT_NEAR(sh.uv.x, 0.75f, 1e-5f);  // phi = 270 degrees
  // At world +x (local +x on both) the longitude runs along local +y: world +z on the turned sphere.
  Material m = hit(0, Vec3f(1, 0, 0), sh);
  EXPECT_NEAR(sh.uv.x, 0.f, 1e-5f);
  EXPECT_NEAR(dot(shading_frame(v, sh, m).s, Vec3f(0, 0, 1)), 1.f, 1e-5f);
  m = hit(1, Vec3f(1, 0, 0), sh);
  EXPECT_NEAR(dot(shading_frame(v, sh, m).s, Vec3f(0, 1, 0)), 1.f, 1e-5f);
  // The normal map (0, 1, 1) tilts the normal 45 degrees towards +v, the +z pole, on the equator.
  m = hit(2, Vec3f(1, 0, 0), sh);
  EXPECT_NEAR(sh.ns.x, std::sqrt(0.5f), 1e-5f);
  EXPECT_NEAR(sh.ns.z, std::sqrt(0.5f), 1e-5f);
}

// texture_luminance_gradient is the derivative of the bilinear lookup's luminance: against central
// differences of texture_lookup inside texel cells, with a uv scale, rotation and offset, and exactly on a
// ramp (luminance u along u: slope 1).
TEST(Texture, LuminanceGradientIsTheLookupsSlope) {
  PCG32 rng(7, 1);
  TextureDesc t = make_texture(8, 4, [&](int, int) { return RGB(rng.next_float(), rng.next_float(), rng.next_float()); });
  TextureView v = view_of(t);
  auto lum = [&](Vec2f uv) {
    RGB c = texture_lookup(v, uv).rgb();
    return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
  };
  int compared = 0;
  for (int setting = 0; setting < 3; ++setting) {
    if (setting == 1) v.uv_scale = Vec2f(2.f, -1.5f);
    if (setting == 2) {
      v.cos_rot = std::cos(0.7f);
      v.sin_rot = std::sin(0.7f);
      v.uv_offset = Vec2f(0.3f, -0.2f);
    }
    for (int k = 0; k < 200; ++k) {
      Vec2f uv(rng.next_float() * 3.f - 1.f, rng.next_float() * 3.f - 1.f);
      const float h = 1e-4f;
      Vec2f fd((lum(uv + Vec2f(h, 0.f)) - lum(uv - Vec2f(h, 0.f))) / (2.f * h),
               (lum(uv + Vec2f(0.f, h)) - lum(uv - Vec2f(0.f, h))) / (2.f * h));
      Vec2f g = texture_luminance_gradient(v, uv);
      // Float differences of h = 1e-4 in values of order 1: about 1e-3 absolute error; a point within h of a
      // cell border (where the slope jumps) is skipped by comparing with both one-sided differences.
      Vec2f fwd((lum(uv + Vec2f(h, 0.f)) - lum(uv)) / h, (lum(uv + Vec2f(0.f, h)) - lum(uv)) / h);
      if (std::fabs(fwd.x - fd.x) > 0.05f * (1.f + std::fabs(fd.x)) ||
          std::fabs(fwd.y - fd.y) > 0.05f * (1.f + std::fabs(fd.y)))
        continue;
      EXPECT_NEAR(g.x, fd.x, 0.02f * (1.f + std::fabs(fd.x))) << setting << " " << uv.x << " " << uv.y;
      EXPECT_NEAR(g.y, fd.y, 0.02f * (1.f + std::fabs(fd.y))) << setting << " " << uv.x << " " << uv.y;
      ++compared;
    }
  }
  EXPECT_GT(compared, 500);  // of 600: few points lie within h of a cell border
  TextureDesc ramp = make_texture(8, 2, [](int x, int) { return RGB((float(x) + 0.5f) / 8.f); });
  TextureView r = view_of(ramp);
  Vec2f g = texture_luminance_gradient(r, Vec2f(0.4f, 0.3f));
  EXPECT_NEAR(g.x, 1.f, 1e-5f);
  EXPECT_NEAR(g.y, 0.f, 1e-6f);
}

// Bump mapping: a height h = scale L(u) rising along u on a plane (u = x) tilts the normal away from the
// rise, to normalize(-dh/dx, 0, 1); a height rising with v does so along y; on a sphere of radius 2 a height
// growing towards the +z pole tilts the equator's normal towards -z by atan(dh/dv / |dp/dv|), |dp/dv| = pi r.
TEST(Texture, BumpMapTiltsTheNormalAgainstTheSlope) {
  SceneDesc d;
  d.textures.push_back(make_texture(8, 2, [](int x, int) { return RGB((float(x) + 0.5f) / 8.f); }));  // L = u
  d.textures.push_back(make_texture(2, 8, [](int, int y) { return RGB((7.5f - float(y)) / 8.f); }));  // L = v
  for (int k = 0; k < 2; ++k) {
    Material m = make_diffuse(RGB(0.5f));
    m.tex_bump = k;
    m.bump_scale = 0.3f;
    d.add_material("bump" + std::to_string(k), m);
  }
  for (int k = 0; k < 2; ++k) add_unit_quad(d, {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, k, 3.f * float(k));  // u = x, v = y
  ShapeDesc sp;
  sp.type = ShapeType::kSphere;
  sp.radius = 2.f;
  sp.center = Vec3f(0.f, 0.f, -10.f);
  sp.material = 1;
  d.shapes.push_back(sp);
  d.lights.push_back(Light{});
  auto sc = Scene::build(d);
  const SceneView& v = sc->view();
  auto shade = [&](Vec3f o, Vec3f dir) {
    Ray r{o, dir, kInf};
    Hit h;
    EXPECT_TRUE(scene_intersect(v, r, h));
    SurfaceHit sh = make_surface_hit(v, r, h);
    surface_material(v, sh);
    return sh.ns;
  };
  Vec3f n = shade(Vec3f(0.4f, 0.3f, 1.f), Vec3f(0, 0, -1));
  Vec3f want = normalize(Vec3f(-0.3f, 0.f, 1.f));  // dh/dx = 0.3 x dL/du = 0.3
  EXPECT_NEAR(n.x, want.x, 1e-5f);
  EXPECT_NEAR(n.y, 0.f, 1e-6f);
  EXPECT_NEAR(n.z, want.z, 1e-5f);
  n = shade(Vec3f(3.4f, 0.3f, 1.f), Vec3f(0, 0, -1));
  EXPECT_NEAR(n.x, 0.f, 1e-6f);
  EXPECT_NEAR(n.y, want.x, 1e-5f);
  n = shade(Vec3f(5.f, 0.f, -10.f), Vec3f(-1, 0, 0));  // the equator at +x: u = 0, v = 0.5
  float tilt = std::atan(0.3f / (kPi * 2.f));
  EXPECT_NEAR(n.x, std::cos(tilt), 1e-5f);
  EXPECT_NEAR(n.z, -std::sin(tilt), 1e-5f);
}

TEST(EnvMap, OrientationFollowsMitsubaConvention) {
  // Column u = 0.25 is +x, u = 0.5 is +z, u = 0 is -z; the top row is +y.
  EXPECT_NEAR(length(envmap_direction_local(Vec2f(0.25f, 0.5f)) - Vec3f(1, 0, 0)), 0.f, 1e-6f);
  EXPECT_NEAR(length(envmap_direction_local(Vec2f(0.5f, 0.5f)) - Vec3f(0, 0, 1)), 0.f, 1e-6f);
  EXPECT_NEAR(length(envmap_direction_local(Vec2f(0.f, 0.5f)) - Vec3f(0, 0, -1)), 0.f, 1e-6f);
  EXPECT_NEAR(envmap_direction_local(Vec2f(0.3f, 0.f)).y, 1.f, 1e-6f);
  PCG32 rng(3, 4);
  for (int i = 0; i < 1000; ++i) {
    Vec2f uv(rng.next_float(), 0.01f + 0.98f * rng.next_float());
    Vec2f back = envmap_image_uv(envmap_direction_local(uv));
    EXPECT_NEAR(back.x, uv.x, 2e-5f);
    EXPECT_NEAR(back.y, uv.y, 2e-5f);
  }
  // A rotated map: the sun texel's world direction is to_world of its local direction.
  TextureDesc t = sky_texture(true);
  Affine rot = rotation_x(90.f);
  auto sc = Scene::build(env_scene(t, rot));
  const SceneView& v = sc->view();
  Vec3f sun_local = envmap_direction_local(Vec2f(11.5f / 16.f, 2.5f / 8.f));
  Vec3f sun_world = rot.vector(sun_local);
  EXPECT_NEAR(envmap_eval(v.envmap, sun_world).x, 200.f, 1e-3f);
  EXPECT_NEAR(envmap_eval(v.envmap, sun_local).x, 0.2f + 0.1f * 1, 0.5f);  // not the sun
}

TEST(EnvMap, SamplingFollowsItsDensity) {
  for (float deg : {0.f, 30.f}) {
    auto sc = Scene::build(env_scene(sky_texture(false), rotation_x(deg)));
    const SceneView& v = sc->view();
    const Light& l = v.lights[v.environment_light];
    PCG32 rng(11, 12);
    auto sample = [&]() {
      LightSample ls;
      bool ok = sample_light(v, l, Vec3f(0.f), Vec2f(rng.next_float(), rng.next_float()), ls);
      return chi2::SampleDir{ok, ls.wi, false};
    };
    auto pdf = [&](Vec3f w) { return environment_pdf(v, l, w); };
    chi2::Options o;
    o.samples = 1000000;
    o.n_tests = 2;
    chi2::Result r = chi2::test_sphere(32, sample, pdf, o);
    EXPECT_TRUE(r.passed) << r.report;
    // The density integrates to one (quadrature error bound + float slack).
    EXPECT_NEAR(r.pdf_integral, 1.0, 4.0 * r.quad_error + 1e-4) << r.report;
  }
}

TEST(EnvMap, RadianceIntegralMatchesTexelSum) {
  // Nearest lookup: int L dw = sum_ij L_ij * dphi * (cos(theta_top) - cos(theta_bottom)).
  TextureDesc t = sky_texture(true);
  auto sc = Scene::build(env_scene(t, rotation_x(20.f), RGB(2.f)));
  const SceneView& v = sc->view();
  double exact = 0.0;
  for (int y = 0; y < t.height; ++y) {
    double band = (2.0 * chi2::kPi / t.width) *
                  (std::cos(chi2::kPi * y / t.height) - std::cos(chi2::kPi * (y + 1) / t.height));
    for (int x = 0; x < t.width; ++x) exact += 2.0 * t.rgba[(size_t(y) * t.width + x) * 4] * band;
  }
  const Light& l = v.lights[v.environment_light];
  PCG32 rng(5, 6);
  const int n = 400000;
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < n; ++i) {
    LightSample ls;
    double x = 0.0;
    if (sample_light(v, l, Vec3f(0.f), Vec2f(rng.next_float(), rng.next_float()), ls)) x = ls.Li.x / ls.pdf;
    sum += x;
    sum2 += x * x;
  }
  double mean = sum / n, se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
  EXPECT_NEAR(mean, exact, 4.0 * se + 1e-6 * exact) << "se " << se;  // 4 standard errors
  // Photons: E[flux weight] = (disk area) * int L dw over the directions they travel.
  double psum = 0.0, psum2 = 0.0;
  for (int i = 0; i < n; ++i) {
    EmitSample e;
    double x = 0.0;
    if (sample_emission(v, l, Vec2f(rng.next_float(), rng.next_float()), Vec2f(rng.next_float(), rng.next_float()),
                        0.5f, e))
      x = e.weight.x;
    psum += x;
    psum2 += x * x;
  }
  double R = v.bsphere_radius, disk = chi2::kPi * R * R;
  double pmean = psum / n, pse = std::sqrt(std::max(0.0, psum2 / n - pmean * pmean) / n);
  EXPECT_NEAR(pmean, disk * exact, 4.0 * pse + 1e-6 * disk * exact);
}

TEST(Absorption, IndexMatchedAbsorbingCubeTransmitsExpMinusSigmaD) {
  // Camera -> absorbing cube of side 2 with eta = 1 (no refraction, no Fresnel)
  // -> an emitter of radiance 1: every pixel that sees the emitter through the
  // cube is exp(-2 sigma) exactly (no noise: the path is deterministic).
  SceneDesc d;
  d.name = "absorb";
  Material glass = make_dielectric(1.f);
  glass.absorption = RGB(0.1f, 0.5f, 1.f);
  d.add_material("glass", glass);
  d.add_material("black", make_diffuse(RGB(0.f)));
  ShapeDesc cube;
  cube.type = ShapeType::kCube;
  cube.material = 0;
  d.shapes.push_back(cube);
  ShapeDesc light;
  light.type = ShapeType::kRectangle;
  light.material = 1;
  light.emission = RGB(1.f);
  Affine t;
  t.m[0][0] = t.m[1][1] = 10.f;
  t.m[2][3] = -5.f;
  light.to_world = t;
  d.shapes.push_back(light);
  d.camera.position = Vec3f(0, 0, 10);
  d.camera.target = Vec3f(0, 0, 0);
  d.camera.fov_degrees = 5.f;
  d.camera.width = d.camera.height = 8;
  auto sc = Scene::build(d);
  RenderOptions o;
  o.spp = 4;
  o.seed = 1;
  RenderJob job(sc, o);
  job.run();
  std::vector<float> img = job.image();
  // The centre pixels look straight through 2 units of glass (4 x 4 centre block).
  for (int y = 2; y < 6; ++y)
    for (int x = 2; x < 6; ++x) {
      const float* p = &img[(size_t(y) * 8 + x) * 3];
      EXPECT_NEAR(p[0], std::exp(-0.2f), 2e-3f) << x << "," << y;  // slightly oblique rays: path >= 2
      EXPECT_NEAR(p[1], std::exp(-1.0f), 2e-3f);
      EXPECT_NEAR(p[2], std::exp(-2.0f), 2e-3f);
    }
}

// stb_image_write is compiled into Debian's libstb.
extern "C" int stbi_write_png(const char* filename, int w, int h, int comp, const void* data, int stride_in_bytes);
extern "C" int stbi_write_jpg(const char* filename, int w, int h, int comp, const void* data, int quality);
extern "C" int stbi_write_hdr(const char* filename, int w, int h, int comp, const float* data);

TEST(TextureFiles, EveryFormatDecodesOnceWithItsColourSpace) {
  namespace fs = std::filesystem;
  fs::path dir = fs::temp_directory_path() / "caustica_tex_files";
  fs::create_directories(dir);
  const unsigned char px8[4 * 3] = {128, 128, 128, 255, 0, 0, 0, 255, 0, 0, 0, 255};  // 2 x 2
  const float pxf[4 * 3] = {0.5f, 0.5f, 0.5f, 2.f, 0.f, 0.f, 0.f, 3.f, 0.f, 0.f, 0.f, 4.f};
  std::string png = (dir / "t.png").string(), jpg = (dir / "t.jpg").string(), hdr = (dir / "t.hdr").string(),
              exr = (dir / "t.exr").string();
  ASSERT_TRUE(stbi_write_png(png.c_str(), 2, 2, 3, px8, 6));
  ASSERT_TRUE(stbi_write_jpg(jpg.c_str(), 2, 2, 3, px8, 100));
  ASSERT_TRUE(stbi_write_hdr(hdr.c_str(), 2, 2, 3, pxf));
  write_image(exr, std::vector<float>(pxf, pxf + 12), 2, 2);
  SceneDesc d;
  // sRGB 128/255 -> linear 0.2158605 (IEC 61966-2-1); raw: 128/255.
  int a = load_texture(d, png, true, "s.json");
  EXPECT_NEAR(d.textures[a].rgba[0], 0.2158605f, 1e-6f);
  EXPECT_EQ(d.textures[a].rgba[3], 1.f);  // RGB files get alpha 1
  int b = load_texture(d, png, false, "s.json");
  EXPECT_NE(a, b);
  EXPECT_NEAR(d.textures[b].rgba[0], 128.f / 255.f, 1e-6f);
  EXPECT_EQ(load_texture(d, png, true, "s.json"), a);  // cached: decoded once
  EXPECT_EQ(d.textures.size(), 2u);
  int j = load_texture(d, jpg, true, "s.json");
  EXPECT_NEAR(d.textures[j].rgba[0], 0.2158605f, 0.02f);  // lossy at quality 100: a few codes off
  // HDR and EXR are linear floats whatever the flag says.
  for (const std::string& f : {hdr, exr}) {
    int k = load_texture(d, f, true, "s.json");
    EXPECT_NEAR(d.textures[k].rgba[0], 0.5f, 0.5f / 128.f) << f;  // RGBE keeps 8 mantissa bits
    EXPECT_NEAR(d.textures[k].rgba[4], 2.f, 2.f / 128.f) << f;
    EXPECT_NEAR(d.textures[k].rgba[4 * 3 + 2], 4.f, 4.f / 128.f) << f;
  }
  std::string missing = (dir / "none.png").string();
  try {
    load_texture(d, missing, true, "s.json");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "s.json: texture file '" + missing + "' does not exist");
  }
  std::string bad = (dir / "bad.png").string();
  { std::ofstream(bad) << "not a png"; }
  try {
    load_texture(d, bad, true, "s.json");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("s.json: cannot read texture '" + bad + "': ", 0), 0u) << e.what();
  }
}
