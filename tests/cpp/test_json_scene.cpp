// caustica's JSON scene format: every built-in scene and every material/light
// kind written by json_writer reads back to the same SceneDesc; the new keys
// (mesh files, named meshes, textures, environment maps, look_at and listed
// transforms, cameras, film, integrator defaults) and their exact error messages.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include "caustica/base/error.h"
#include "caustica/film/image_io.h"
#include "caustica/scene/builtin/builtin.h"
#include "caustica/scene/json_writer.h"
#include "caustica/scene/volume_io.h"
#include "caustica/scene/load.h"
#include "caustica/scene/loaders/json_loader.h"

using namespace caustica;
namespace fs = std::filesystem;

namespace {

// Bitwise float equality (tells -0 from 0).
bool same(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }
#define EXPECT_SAME_F(a, b) EXPECT_TRUE(same(a, b)) << #a << " = " << (a) << " vs " << (b)
void expect_same(Vec3f a, Vec3f b, const std::string& what) {
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(same(a[i], b[i])) << what << "[" << i << "]: " << a[i] << " vs " << b[i];
}
void expect_same(Vec2f a, Vec2f b, const std::string& what) {
  EXPECT_TRUE(same(a.x, b.x) && same(a.y, b.y)) << what;
}

void expect_camera_eq(const CameraDesc& a, const CameraDesc& b, const std::string& w) {
  EXPECT_EQ(a.name, b.name) << w;
  expect_same(a.position, b.position, w + ".position");
  expect_same(a.target, b.target, w + ".target");
  expect_same(a.up, b.up, w + ".up");
  EXPECT_SAME_F(a.fov_degrees, b.fov_degrees);
  EXPECT_EQ(int(a.fov_axis), int(b.fov_axis)) << w;
  EXPECT_SAME_F(a.aperture_radius, b.aperture_radius);
  EXPECT_SAME_F(a.focus_distance, b.focus_distance);
  EXPECT_EQ(a.width, b.width) << w;
  EXPECT_EQ(a.height, b.height) << w;
  EXPECT_EQ(a.flip_x, b.flip_x) << w;
}

void expect_material_eq(const Material& a, const Material& b, const std::string& w) {
  EXPECT_EQ(int(a.type), int(b.type)) << w;
  EXPECT_EQ(a.flags, b.flags) << w;
  expect_same(a.diffuse, b.diffuse, w + ".diffuse");
  expect_same(a.specular, b.specular, w + ".specular");
  expect_same(a.transmission, b.transmission, w + ".transmission");
  expect_same(a.eta_c, b.eta_c, w + ".eta_c");
  expect_same(a.k_c, b.k_c, w + ".k_c");
  EXPECT_TRUE(same(a.eta, b.eta)) << w << ".eta";
  EXPECT_TRUE(same(a.alpha_x, b.alpha_x)) << w << ".alpha_x " << a.alpha_x << " vs " << b.alpha_x;
  EXPECT_TRUE(same(a.alpha_y, b.alpha_y)) << w << ".alpha_y";
  EXPECT_TRUE(same(a.exponent, b.exponent)) << w << ".exponent";
  EXPECT_TRUE(same(a.fdr_int, b.fdr_int)) << w << ".fdr_int";
  EXPECT_TRUE(same(a.metallic, b.metallic)) << w << ".metallic";
  EXPECT_TRUE(same(a.transmission_weight, b.transmission_weight)) << w << ".transmission_weight";
  EXPECT_EQ(a.tex_color, b.tex_color) << w;
  EXPECT_EQ(a.tex_roughness, b.tex_roughness) << w;
  EXPECT_EQ(a.tex_normal, b.tex_normal) << w;
  EXPECT_TRUE(same(a.normal_scale, b.normal_scale)) << w << ".normal_scale";
  EXPECT_EQ(a.tex_bump, b.tex_bump) << w;
  EXPECT_EQ(a.tex_aniso, b.tex_aniso) << w;
  EXPECT_TRUE(same(a.clearcoat, b.clearcoat)) << w << ".clearcoat";
  EXPECT_TRUE(same(a.clearcoat_alpha, b.clearcoat_alpha)) << w << ".clearcoat_alpha";
  EXPECT_EQ(a.tex_clearcoat, b.tex_clearcoat) << w;
  EXPECT_EQ(a.tex_clearcoat_roughness, b.tex_clearcoat_roughness) << w;
  EXPECT_EQ(a.tex_clearcoat_normal, b.tex_clearcoat_normal) << w;
  EXPECT_TRUE(same(a.clearcoat_normal_scale, b.clearcoat_normal_scale)) << w << ".clearcoat_normal_scale";
  EXPECT_TRUE(same(a.specular_weight, b.specular_weight)) << w << ".specular_weight";
  EXPECT_EQ(a.tex_specular, b.tex_specular) << w;
  EXPECT_EQ(a.tex_specular_color, b.tex_specular_color) << w;
  EXPECT_EQ(a.tex_transmission, b.tex_transmission) << w;
  expect_same(a.sheen_color, b.sheen_color, w + ".sheen_color");
  EXPECT_TRUE(same(a.sheen_roughness, b.sheen_roughness)) << w << ".sheen_roughness";
  EXPECT_EQ(a.tex_sheen_color, b.tex_sheen_color) << w;
  EXPECT_EQ(a.tex_sheen_roughness, b.tex_sheen_roughness) << w;
  EXPECT_TRUE(same(a.iridescence, b.iridescence)) << w << ".iridescence";
  EXPECT_TRUE(same(a.iridescence_eta, b.iridescence_eta)) << w << ".iridescence_eta";
  EXPECT_TRUE(same(a.iridescence_thickness, b.iridescence_thickness)) << w << ".iridescence_thickness";
  if (a.tex_iridescence_thickness >= 0)  // the minimum means nothing without the texture
    EXPECT_TRUE(same(a.iridescence_thickness_min, b.iridescence_thickness_min)) << w << ".iridescence_thickness_min";
  EXPECT_EQ(a.tex_iridescence, b.tex_iridescence) << w;
  EXPECT_EQ(a.tex_iridescence_thickness, b.tex_iridescence_thickness) << w;
  EXPECT_TRUE(same(a.diffuse_transmission, b.diffuse_transmission)) << w << ".diffuse_transmission";
  EXPECT_EQ(a.tex_diffuse_transmission, b.tex_diffuse_transmission) << w;
  EXPECT_EQ(a.tex_diffuse_transmission_color, b.tex_diffuse_transmission_color) << w;
  EXPECT_TRUE(same(a.metallic, b.metallic)) << w << ".metallic";
  EXPECT_TRUE(same(a.transmission_weight, b.transmission_weight)) << w << ".transmission_weight";
  EXPECT_TRUE(same(a.spec_tint, b.spec_tint)) << w << ".spec_tint";
  EXPECT_TRUE(same(a.sheen, b.sheen)) << w << ".sheen";
  EXPECT_TRUE(same(a.sheen_tint, b.sheen_tint)) << w << ".sheen_tint";
  EXPECT_TRUE(same(a.flatness, b.flatness)) << w << ".flatness";
  EXPECT_TRUE(same(a.clearcoat_gloss, b.clearcoat_gloss)) << w << ".clearcoat_gloss";
  EXPECT_EQ(a.tex_metallic, b.tex_metallic) << w;
  EXPECT_EQ(a.tex_spec_tint, b.tex_spec_tint) << w;
  EXPECT_EQ(a.tex_sheen, b.tex_sheen) << w;
  EXPECT_EQ(a.tex_sheen_tint, b.tex_sheen_tint) << w;
  EXPECT_EQ(a.tex_flatness, b.tex_flatness) << w;
  EXPECT_EQ(a.tex_clearcoat_gloss, b.tex_clearcoat_gloss) << w;
  EXPECT_TRUE(same(a.bump_scale, b.bump_scale)) << w << ".bump_scale";
  expect_same(a.absorption, b.absorption, w + ".absorption");
}

// Every field of two descriptions (textures compared by pixels and settings;
// `texture_names` false skips their names, which are file paths).
void expect_desc_eq(const SceneDesc& a, const SceneDesc& b, bool texture_names = false) {
  EXPECT_EQ(a.name, b.name);
  expect_camera_eq(a.camera, b.camera, "camera");
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (size_t i = 0; i < a.cameras.size(); ++i) expect_camera_eq(a.cameras[i], b.cameras[i], "cameras/" + std::to_string(i));
  EXPECT_TRUE(a.filter == b.filter);
  EXPECT_EQ(a.material_names, b.material_names);
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (size_t i = 0; i < a.materials.size(); ++i) expect_material_eq(a.materials[i], b.materials[i], a.material_names[i]);
  ASSERT_EQ(a.meshes.size(), b.meshes.size());
  for (size_t i = 0; i < a.meshes.size(); ++i) {
    const MeshDesc &x = a.meshes[i], &y = b.meshes[i];
    EXPECT_EQ(x.name, y.name);
    ASSERT_EQ(x.positions.size(), y.positions.size());
    for (size_t k = 0; k < x.positions.size(); ++k) expect_same(x.positions[k], y.positions[k], "position");
    ASSERT_EQ(x.normals.size(), y.normals.size());
    for (size_t k = 0; k < x.normals.size(); ++k) expect_same(x.normals[k], y.normals[k], "normal");
    ASSERT_EQ(x.uvs.size(), y.uvs.size());
    for (size_t k = 0; k < x.uvs.size(); ++k) expect_same(x.uvs[k], y.uvs[k], "uv");
    ASSERT_EQ(x.tangents.size(), y.tangents.size());
    for (size_t k = 0; k < x.tangents.size(); ++k) {
      expect_same(x.tangents[k].t, y.tangents[k].t, "tangent");
      EXPECT_EQ(x.tangents[k].w, y.tangents[k].w) << "tangent handedness";
    }
    ASSERT_EQ(x.colors.size(), y.colors.size());
    for (size_t k = 0; k < x.colors.size(); ++k) expect_same(x.colors[k], y.colors[k], "vertex colour");
    EXPECT_EQ(x.indices, y.indices);
  }
  ASSERT_EQ(a.shapes.size(), b.shapes.size());
  for (size_t i = 0; i < a.shapes.size(); ++i) {
    const ShapeDesc &x = a.shapes[i], &y = b.shapes[i];
    std::string w = "shape " + x.name;
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(int(x.type), int(y.type)) << w;
    EXPECT_EQ(x.mesh, y.mesh) << w;
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 4; ++k) EXPECT_TRUE(same(x.to_world.m[r][k], y.to_world.m[r][k])) << w << " to_world " << r << k;
    expect_same(x.center, y.center, w + ".center");
    EXPECT_TRUE(same(x.radius, y.radius)) << w;
    EXPECT_EQ(x.material, y.material) << w;
    expect_same(x.emission, y.emission, w + ".emission");
    EXPECT_EQ(x.emission_texture, y.emission_texture) << w;
    EXPECT_EQ(x.emission_two_sided, y.emission_two_sided) << w;
    EXPECT_EQ(x.flip_normals, y.flip_normals) << w;
  }
  ASSERT_EQ(a.lights.size(), b.lights.size());
  for (size_t i = 0; i < a.lights.size(); ++i) {
    const Light &x = a.lights[i], &y = b.lights[i];
    std::string w = "light " + std::to_string(i);
    EXPECT_EQ(int(x.type), int(y.type)) << w;
    EXPECT_EQ(x.two_sided, y.two_sided) << w;
    expect_same(x.L, y.L, w + ".L");
    expect_same(x.p, y.p, w + ".p");
    expect_same(x.dir, y.dir, w + ".dir");
    EXPECT_TRUE(same(x.cos_total, y.cos_total)) << w << " cos_total " << x.cos_total << " vs " << y.cos_total;
    EXPECT_TRUE(same(x.cos_falloff_start, y.cos_falloff_start)) << w << " cos_falloff_start";
    EXPECT_EQ(x.texture, y.texture) << w;
  }
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 4; ++k) EXPECT_TRUE(same(a.environment_to_world.m[r][k], b.environment_to_world.m[r][k]));
  ASSERT_EQ(a.textures.size(), b.textures.size());
  for (size_t i = 0; i < a.textures.size(); ++i) {
    const TextureDesc &x = a.textures[i], &y = b.textures[i];
    if (texture_names) EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.width, y.width);
    EXPECT_EQ(x.height, y.height);
    EXPECT_EQ(x.srgb, y.srgb);
    EXPECT_EQ(int(x.wrap_u), int(y.wrap_u));
    EXPECT_EQ(int(x.wrap_v), int(y.wrap_v));
    EXPECT_EQ(x.nearest, y.nearest);
    expect_same(x.uv_offset, y.uv_offset, "uv_offset");
    expect_same(x.uv_scale, y.uv_scale, "uv_scale");
    EXPECT_TRUE(same(x.uv_rotation, y.uv_rotation)) << x.uv_rotation << " vs " << y.uv_rotation;
    ASSERT_EQ(x.rgba.size(), y.rgba.size());
    for (size_t k = 0; k < x.rgba.size(); ++k)
      if (k % 4 != 3) ASSERT_TRUE(same(x.rgba[k], y.rgba[k])) << "texture " << i << " value " << k;
  }
  EXPECT_EQ(a.medium_names, b.medium_names);
  ASSERT_EQ(a.media.size(), b.media.size());
  for (size_t i = 0; i < a.media.size(); ++i) {
    const Medium &x = a.media[i], &y = b.media[i];
    expect_same(x.sigma_a, y.sigma_a, "medium sigma_a");
    expect_same(x.sigma_s, y.sigma_s, "medium sigma_s");
    EXPECT_TRUE(same(x.g, y.g)) << "medium " << i;
    EXPECT_EQ(x.grid, y.grid) << "medium " << i;
  }
  ASSERT_EQ(a.grids.size(), b.grids.size());
  for (size_t i = 0; i < a.grids.size(); ++i) {
    const MediumGridDesc &x = a.grids[i], &y = b.grids[i];
    EXPECT_EQ(x.nx, y.nx);
    EXPECT_EQ(x.ny, y.ny);
    EXPECT_EQ(x.nz, y.nz);
    EXPECT_EQ(x.nearest, y.nearest);
    EXPECT_EQ(x.clamp, y.clamp);
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 4; ++k) EXPECT_TRUE(same(x.to_world.m[r][k], y.to_world.m[r][k])) << "grid to_world";
    ASSERT_EQ(x.values.size(), y.values.size());
    for (size_t k = 0; k < x.values.size(); ++k) ASSERT_TRUE(same(x.values[k], y.values[k])) << "grid value " << k;
  }
  EXPECT_EQ(a.camera.medium, b.camera.medium);
  for (size_t i = 0; i < a.shapes.size(); ++i) {
    const ShapeDesc &x = a.shapes[i], &y = b.shapes[i];
    EXPECT_EQ(x.medium_interface, y.medium_interface) << x.name;
    EXPECT_EQ(x.interior, y.interior) << x.name;
    EXPECT_EQ(x.exterior, y.exterior) << x.name;
  }
  EXPECT_EQ(a.max_depth, b.max_depth);
  EXPECT_EQ(a.integrator.type, b.integrator.type);
  EXPECT_EQ(a.integrator.sampler, b.integrator.sampler);
  EXPECT_EQ(a.integrator.spp, b.integrator.spp);
  EXPECT_EQ(a.integrator.time, b.integrator.time);
  EXPECT_EQ(a.integrator.rr_depth, b.integrator.rr_depth);
  EXPECT_EQ(a.integrator.photons, b.integrator.photons);
  EXPECT_TRUE(same(a.integrator.radius, b.integrator.radius));
  EXPECT_TRUE(same(a.integrator.alpha, b.integrator.alpha));
  EXPECT_EQ(a.integrator.k, b.integrator.k);
}

// A fresh directory per test.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) {
    path = fs::temp_directory_path() / ("caustica-json-" + name + "-" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string file(const std::string& n) const { return (path / n).string(); }
  std::string write(const std::string& n, const std::string& text) const {
    std::ofstream(file(n)) << text;
    return file(n);
  }
};

std::string error_of(const std::string& text, const std::string& source = "s.json", const std::string& base = "") {
  try {
    load_json_scene_text(text, source, base);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

// A minimal scene with `extra` top-level members and `shape` as its one shape.
std::string scene_with(const std::string& extra, const std::string& shape = R"({"type": "cube"})") {
  return R"({"camera": {"position": [0, 0, 5], "target": [0, 0, 0]}, "shapes": [)" + shape + "]" +
         (extra.empty() ? "" : ", " + extra) + "}";
}

}  // namespace

TEST(JsonRoundTrip, EveryBuiltinSceneReadsBackExactly) {
  for (const auto& [name, what] : builtin_scenes()) {
    SCOPED_TRACE(name);
    SceneDesc d = builtin_scene(name);
    std::string text = scene_desc_to_json(d, name);
    // Density grids are files beside the JSON (as write_scene_json writes them).
    TempDir dir("builtin-" + name);
    for (size_t g = 0; g < d.grids.size(); ++g) write_vol_grid(d.grids[g], dir.file(exported_grid_name(name, g)));
    SceneDesc back = load_json_scene_text(text, name + ".json", dir.path.string());
    expect_desc_eq(d, back);
    EXPECT_EQ(scene_desc_to_json(back, name), text);  // and writing it again gives the same text
  }
}

TEST(JsonRoundTrip, FloatsUseTheFewestDigits) {
  SceneDesc d = builtin_scene("cornell");
  std::string text = scene_desc_to_json(d);
  EXPECT_NE(text.find("[0.885809, 0.698859, 0.666422]"), std::string::npos);  // not 0.88580900430679321
  EXPECT_NE(text.find("\"fov\": 39.3077"), std::string::npos);
}

TEST(JsonRoundTrip, LongNamesStayStrings) {
  // A string longer than a line (names made from file paths, as the XML loader's) is written as a string: it
  // once fell through to the array branch and came out as [].
  SceneDesc d = builtin_scene("cornell");
  std::string long_name = "instance@/a/rather/long/path/to/a/scene/file/" + std::string(120, 'x') + ".xml:20/shape";
  d.shapes[0].name = long_name;
  SceneDesc back = load_json_scene_text(scene_desc_to_json(d), "long.json");
  EXPECT_EQ(back.shapes[0].name, long_name);
}

TEST(JsonRoundTrip, EveryMaterialAndLightKindWithTextures) {
  TempDir dir("kinds");
  SceneDesc d;
  d.name = "kinds";
  d.camera.position = {0.1f, 0.2f, 3.f};
  d.camera.target = {0.f, 0.f, -1.f / 3.f};
  d.camera.fov_axis = CameraDesc::FovAxis::kY;
  d.camera.aperture_radius = 0.01f;
  d.camera.focus_distance = 2.5f;
  d.camera.width = 33;
  d.camera.height = 17;
  d.camera.name = "main";
  CameraDesc side = d.camera;
  side.name = "side";
  side.position = {3.f, 0.f, 0.f};
  side.width = 64;
  side.flip_x = true;
  d.cameras = {d.camera, side};
  d.filter = make_filter(FilterType::kMitchell, 2.5f, 0.2f, 0.4f);  // written as an object
  d.max_depth = 7;
  d.integrator.type = "sppm";
  d.integrator.spp = 12;
  d.integrator.time = 1.25;
  d.integrator.rr_depth = 3;
  d.integrator.sampler = "independent";
  d.integrator.photons = 1000;
  d.integrator.radius = 0.01f;
  d.integrator.alpha = 2.f / 3.f;
  d.integrator.k = 20;
  // Textures: a 3x2 colour image and a 2x2 data image, in memory.
  for (int t = 0; t < 2; ++t) {
    TextureDesc tex;
    tex.name = "mem" + std::to_string(t);
    tex.width = 3 - t;
    tex.height = 2;
    tex.srgb = t == 0;
    for (int k = 0; k < tex.width * tex.height; ++k)
      for (int ch = 0; ch < 4; ++ch) tex.rgba.push_back(ch == 3 ? 1.f : float(k * 4 + ch) / 7.f + 1e-7f * t);
    if (t == 1) {
      tex.wrap_u = TexWrap::kMirror;
      tex.wrap_v = TexWrap::kClamp;  // an axis each (written as [u, v])
      tex.nearest = true;
      tex.uv_scale = {2.f, 0.5f};
      tex.uv_offset = {0.1f, -0.f};
      tex.uv_rotation = 0.3f;
    }
    d.textures.push_back(tex);
  }
  Material diffuse = make_diffuse(RGB(0.2f, 0.3f, 0.4f), true);
  diffuse.tex_color = 0;
  diffuse.tex_normal = 1;
  diffuse.normal_scale = 0.7f;
  d.add_material("diffuse", diffuse);
  d.add_material("mirror", make_mirror(RGB(0.9f)));
  Material rough_mirror = make_mirror(RGB(0.8f));
  rough_mirror.type = MaterialType::kRoughConductor;
  rough_mirror.alpha_x = 0.1f;
  rough_mirror.alpha_y = 0.3f;
  d.add_material("rough mirror/aniso", rough_mirror);
  d.add_material("gold", make_conductor({0.143f, 0.374f, 1.442f}, {3.983f, 2.385f, 1.603f}, RGB(1.f), 0.2f));
  Material tex_rough = make_conductor(RGB(0.2f), RGB(3.f), RGB(1.f), 0.5f);
  tex_rough.tex_roughness = 1;
  d.add_material("textured roughness", tex_rough);
  Material bumpy = make_plastic(RGB(0.3f), 1.5f, RGB(1.f));
  bumpy.tex_bump = 1;
  bumpy.bump_scale = 0.015f;
  d.add_material("bumpy", bumpy);
  Material brushed = make_conductor(RGB(0.2f), RGB(3.f), RGB(1.f), 0.1f);
  brushed.alpha_x = 0.4f;
  brushed.tex_aniso = 1;
  brushed.aniso_rotation = 0.5f;
  d.add_material("brushed", brushed);
  Material glass = make_dielectric(1.33f, 0.f);
  glass.absorption = {0.5f, 0.1f, 0.f};
  glass.transmission = RGB(0.9f, 0.95f, 1.f);
  d.add_material("glass", glass);
  d.add_material("rough glass", make_dielectric(1.5f, 0.05f));
  d.add_material("thin", make_thin_dielectric(1.4f));
  d.add_material("plastic", make_plastic(RGB(0.1f, 0.2f, 0.7f), 1.6f, RGB(0.9f)));
  d.add_material("difftrans", make_diffuse_transmission(RGB(0.3f), RGB(0.6f)));
  Material leafy = make_diffuse_transmission(RGB(0.2f), RGB(0.5f, 0.7f, 0.1f));
  leafy.tex_color = 0, leafy.tex_diffuse_transmission_color = 1;  // reflectance and transmittance textures
  d.add_material("difftrans textures", leafy);
  d.add_material("phong", make_phong(RGB(0.1f), RGB(0.7f), 50.f));
  d.add_material("pbr", make_metallic_roughness(RGB(0.9f, 0.5f, 0.1f), 0.25f, 0.7f, 0.5f, 1.45f));
  Material pbr_odd = make_metallic_roughness(RGB(0.5f), 1.f, 0.f);
  pbr_odd.alpha_x = pbr_odd.alpha_y = 0.1f;  // no float r has r * r == 0.1f exactly? written as alpha if not
  pbr_odd.tex_roughness = 1;
  pbr_odd.tex_color = 0;
  d.add_material("pbr odd alpha", pbr_odd);
  Material paint = make_metallic_roughness(RGB(0.6f, 0.05f, 0.05f), 0.4f, 0.5f);
  paint.clearcoat = 0.9f;
  paint.clearcoat_alpha = 0.3f * 0.3f;
  paint.tex_clearcoat_roughness = 1;
  d.add_material("clear coated", paint);
  Material paint_tex = paint;
  paint_tex.clearcoat_alpha = 0.f;
  paint_tex.tex_clearcoat = 1;
  paint_tex.tex_clearcoat_roughness = -1;
  paint_tex.tex_clearcoat_normal = 0;
  paint_tex.clearcoat_normal_scale = 0.75f;
  d.add_material("clear coat texture", paint_tex);
  Material spec = make_metallic_roughness(RGB(0.2f, 0.4f, 0.1f), 0.f, 0.35f);
  spec.specular_weight = 0.4f;
  spec.specular = RGB(1.5f, 1.f, 0.25f);
  d.add_material("specular tint", spec);
  spec.tex_specular = 1;
  spec.tex_specular_color = 0;
  d.add_material("specular textures", spec);
  Material see_through = make_metallic_roughness(RGB(0.9f), 0.f, 0.1f, 0.75f, 1.4f);
  see_through.tex_transmission = 1;
  d.add_material("transmission texture", see_through);
  Material velvet = make_metallic_roughness(RGB(0.3f, 0.05f, 0.1f), 0.f, 0.8f);
  velvet.sheen_color = RGB(0.9f, 0.4f, 0.5f);
  velvet.sheen_roughness = 0.35f;
  d.add_material("sheen", velvet);
  velvet.tex_sheen_color = 0;
  velvet.tex_sheen_roughness = 1;
  d.add_material("sheen textures", velvet);
  Material leaf = make_metallic_roughness(RGB(0.2f, 0.5f, 0.1f), 0.f, 0.6f);
  leaf.diffuse_transmission = 0.4f;
  leaf.transmission = RGB(0.6f, 0.9f, 0.2f);
  d.add_material("diffuse transmission", leaf);
  leaf.tex_diffuse_transmission = 1, leaf.tex_diffuse_transmission_color = 0;
  d.add_material("diffuse transmission textures", leaf);
  Material film = make_metallic_roughness(RGB(0.2f, 0.3f, 0.9f), 0.6f, 0.25f);
  film.iridescence = 0.75f, film.iridescence_eta = 1.45f, film.iridescence_thickness = 520.f;
  d.add_material("iridescence", film);
  film.tex_iridescence = 1, film.tex_iridescence_thickness = 0, film.iridescence_thickness_min = 120.f;
  d.add_material("iridescence textures", film);
  Material disney = make_principled(RGB(0.8f, 0.4f, 0.3f), 0.25f, 0.4f, 0.f, 0.5f, 1.45f);
  disney.spec_tint = 0.1f, disney.sheen = 0.2f, disney.sheen_tint = 0.3f, disney.flatness = 0.4f;
  disney.clearcoat = 0.6f, disney.clearcoat_gloss = 0.7f;
  d.add_material("principled", disney);
  disney.tex_metallic = 0, disney.tex_transmission = 1, disney.tex_spec_tint = 0, disney.tex_sheen = 1;
  disney.tex_sheen_tint = 0, disney.tex_flatness = 1, disney.tex_clearcoat = 0, disney.tex_clearcoat_gloss = 1;
  d.add_material("principled textures", disney);
  Material vc = make_diffuse(RGB(0.7f));
  vc.flags |= kVertexColor;
  d.add_material("vertex coloured", vc);

  MeshDesc m;
  m.name = "tri";
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, -0.f}};
  m.normals = {{0, 0, 1}, {0, 0, 1}, {0.f, 0.6f, 0.8f}};
  m.uvs = {{0, 0}, {1, 0}, {0, 1.f / 3.f}};
  m.tangents = {Tangent{Vec3f(1, 0, 0), 1.f}, Tangent{}, Tangent{normalize(Vec3f(0.6f, 0.f, -0.8f)), -1.f}};
  m.colors = {RGB(0.25f), RGB(1.f, 0.5f, 0.f), RGB(0.1f, 0.2f, 3.f)};  // a grey one too: [r, g, b] all the same
  m.indices = {0, 1, 2};
  d.meshes.push_back(m);
  m.normals.clear();
  m.tangents.clear();
  m.colors.clear();
  d.meshes.push_back(m);  // the same name twice
  for (int i = 0; i < 14; ++i) {
    ShapeDesc s;
    s.name = "s" + std::to_string(i);
    s.type = ShapeType(i % 5);
    s.mesh = s.type == ShapeType::kMesh ? i % 2 : -1;
    s.material = i % int(d.materials.size());
    s.to_world.m[0][3] = 0.1f * float(i);
    s.to_world.m[1][1] = i % 3 == 0 ? -1.f : 1.f;
    s.center = s.type == ShapeType::kSphere ? Vec3f(0.5f, 0.f, -0.25f) : Vec3f(0.f);
    s.radius = s.type == ShapeType::kSphere ? 0.3f : 1.f;
    if (s.type == ShapeType::kSphere) s.to_world.m[1][1] = 1.f;
    if (i == 4) s.emission = RGB(3.f, 2.f, 1.f);
    if (i == 5) {
      s.emission = RGB(2.f);
      s.emission_texture = 0;
      s.emission_two_sided = true;
    }
    s.flip_normals = i == 7;
    d.shapes.push_back(s);
  }
  Light point;
  point.type = LightType::kPoint;
  point.p = {1, 2, 3};
  point.L = RGB(10.f);
  Light spot;
  spot.type = LightType::kSpot;
  spot.p = {0, 1, 0};
  spot.dir = normalize(Vec3f(0.1f, -1.f, 0.2f));
  spot.L = RGB(5.f, 4.f, 3.f);
  spot.cos_total = std::cos(25.f * kPi / 180.f);
  spot.cos_falloff_start = std::cos(20.f * kPi / 180.f);
  Light narrow = spot;
  narrow.cos_total = std::cos(0.5f * kPi / 180.f);
  narrow.cos_falloff_start = 1.f;
  Light sun;
  sun.type = LightType::kDirectional;
  sun.dir = normalize(Vec3f(-1.f, 1.5f, -1.f));
  sun.L = {10.f, 4.f, 0.f};
  Light env;
  env.type = LightType::kEnvironment;
  env.texture = 0;
  env.L = RGB(0.5f);
  d.lights = {point, spot, narrow, sun, env};
  d.environment_to_world.m[0][0] = 0.f;
  d.environment_to_world.m[0][2] = 1.f;
  d.environment_to_world.m[2][0] = -1.f;
  d.environment_to_world.m[2][2] = 0.f;

  std::string path = dir.file("kinds.json");
  write_scene_json(d, path);
  ASSERT_TRUE(fs::exists(dir.file("kinds.tex0.exr")));
  ASSERT_TRUE(fs::exists(dir.file("kinds.tex1.exr")));
  SceneDesc back = load_json_scene_file(path);
  back.name = d.name;
  // The second mesh had the same name; its key was made unique.
  EXPECT_EQ(back.meshes[1].name, "tri#2");
  back.meshes[1].name = "tri";
  expect_desc_eq(d, back);
  // Writing the read-back scene again gives the same text.
  std::ifstream f(path);
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  back.meshes[1].name = "tri#2";
  back.name = "kinds";
  EXPECT_EQ(scene_desc_to_json(back, "kinds"), text);
}

TEST(JsonRoundTrip, SpotAnglesAndTextureRotationsReadBackExactly) {
  // Angles go through acos/cos in double; check many of them.
  for (int i = 1; i < 1800; i += 7) {
    SceneDesc d = builtin_scene("cornell");
    Light spot;
    spot.type = LightType::kSpot;
    spot.cos_total = std::cos(float(i) * 0.1f * kPi / 180.f);
    spot.cos_falloff_start = std::cos(float(i) * 0.05f * kPi / 180.f);
    d.lights.push_back(spot);
    SceneDesc back = load_json_scene_text(scene_desc_to_json(d), "spot.json");
    ASSERT_TRUE(same(back.lights[0].cos_total, spot.cos_total)) << i;
    ASSERT_TRUE(same(back.lights[0].cos_falloff_start, spot.cos_falloff_start)) << i;
  }
}

TEST(JsonLoader, OlderFilesStillLoad) {
  // Resolution in the camera, the filter and max_depth at the top level.
  SceneDesc d = load_json_scene_text(R"({"camera": {"width": 40, "height": 30}, "filter": "tent", "max_depth": 5,
      "shapes": [{"type": "sphere"}], "lights": [{"type": "environment", "radiance": 0.5}]})",
                                     "old.json");
  EXPECT_EQ(d.camera.width, 40);
  EXPECT_EQ(d.camera.height, 30);
  EXPECT_EQ(int(d.filter.type), int(FilterType::kTent));
  EXPECT_EQ(d.max_depth, 5);
  EXPECT_EQ(d.lights[0].texture, -1);
  EXPECT_EQ(d.material_names, std::vector<std::string>{"default"});
}

TEST(JsonLoader, FilmCamerasAndIntegrator) {
  SceneDesc d = load_json_scene_text(R"({
    "film": {"width": 320, "height": 200, "filter": "gaussian"},
    "integrator": {"type": "sppm", "spp": 64, "max_depth": 8, "rr_depth": 4, "photons": 5000, "radius": 0.02,
                   "alpha": 0.6, "k": 30, "sampler": "independent", "time": 2.5},
    "cameras": {"front": {"position": [0, 0, 5]}, "top": {"position": [0, 5, 0], "up": [0, 0, -1], "width": 64}},
    "camera": "top",
    "shapes": [{"type": "cube"}]})",
                                     "f.json");
  EXPECT_EQ(d.camera.name, "top");
  EXPECT_EQ(d.camera.width, 64);
  EXPECT_EQ(d.camera.height, 200);
  ASSERT_EQ(d.cameras.size(), 2u);
  EXPECT_EQ(d.cameras[0].name, "front");  // the file's order, not sorted
  EXPECT_EQ(d.cameras[0].width, 320);
  EXPECT_EQ(int(d.filter.type), int(FilterType::kGaussian));
  EXPECT_EQ(d.max_depth, 8);
  EXPECT_EQ(d.integrator.type, "sppm");
  EXPECT_EQ(d.integrator.spp, 64);
  EXPECT_EQ(d.integrator.rr_depth, 4);
  EXPECT_EQ(d.integrator.photons, 5000);
  EXPECT_FLOAT_EQ(d.integrator.radius, 0.02f);
  EXPECT_FLOAT_EQ(d.integrator.alpha, 0.6f);
  EXPECT_EQ(d.integrator.k, 30);
  EXPECT_EQ(d.integrator.sampler, "independent");
  EXPECT_EQ(d.integrator.time, 2.5);
  // Without "camera", the first named camera; --camera picks another.
  SceneDesc e = load_json_scene_text(R"({"cameras": {"b": {"position": [0, 0, 5]}, "a": {"position": [0, 0, 6]}},
                                         "shapes": [{"type": "cube"}]})",
                                     "e.json");
  EXPECT_EQ(e.camera.name, "b");
  select_camera(e, "a");
  EXPECT_EQ(e.camera.position.z, 6.f);
  try {
    select_camera(e, "c");
    FAIL();
  } catch (const InputError& err) {
    EXPECT_STREQ(err.what(), "e.json: no camera named 'c' (cameras: b, a)");
  }
}

TEST(JsonLoader, TransformsLookAtAndLists) {
  SceneDesc d = load_json_scene_text(scene_with("", R"({"type": "disk", "transform":
      {"look_at": {"origin": [1, 2, 3], "target": [1, 2, 0], "up": [0, 1, 0]}}},
      {"type": "cube", "transform": [{"scale": 2}, {"translate": [1, 0, 0]}, {"rotate": {"axis": [0, 0, 1], "angle": 90}}]})"),
                                     "t.json");
  const Affine& a = d.shapes[0].to_world;
  Vec3f n = a.vector(Vec3f(0, 0, 1)), o = a.point(Vec3f(0.f));
  EXPECT_NEAR(n.z, -1.f, 1e-6f);  // local +z points at the target
  EXPECT_NEAR(o.x, 1.f, 1e-6f);
  EXPECT_NEAR(o.z, 3.f, 1e-6f);
  EXPECT_NEAR(a.vector(Vec3f(0, 1, 0)).y, 1.f, 1e-6f);
  // Scale by 2, move to x = 1, then turn 90 degrees about z: (1, 0, 0) -> (2, 0, 0) -> (3, 0, 0) -> (0, 3, 0).
  Vec3f p = d.shapes[1].to_world.point(Vec3f(1, 0, 0));
  EXPECT_NEAR(p.x, 0.f, 1e-5f);
  EXPECT_NEAR(p.y, 3.f, 1e-5f);
  EXPECT_NEAR(p.z, 0.f, 1e-5f);
}

TEST(JsonLoader, NamedMeshesAreInstanced) {
  SceneDesc d = load_json_scene_text(
      scene_with(R"("meshes": {"tri": {"positions": [[0,0,0],[1,0,0],[0,1,0]], "indices": [0,1,2], "uvs": [[0,0],[1,0],[0,1]]}},
                   "materials": {"red": {"type": "diffuse", "reflectance": [1, 0, 0]}})",
                 R"({"type": "mesh", "mesh": "tri"}, {"type": "mesh", "mesh": "tri", "material": "red",
                     "transform": {"translate": [2, 0, 0]}})"),
      "m.json");
  ASSERT_EQ(d.meshes.size(), 1u);
  ASSERT_EQ(d.shapes.size(), 2u);
  EXPECT_EQ(d.shapes[0].mesh, 0);
  EXPECT_EQ(d.shapes[1].mesh, 0);
  EXPECT_EQ(d.meshes[0].uvs.size(), 3u);
  EXPECT_EQ(d.material_names[d.shapes[1].material], "red");
  EXPECT_EQ(d.material_names[d.shapes[0].material], "default");
  SceneStats st = scene_stats(d);
  EXPECT_EQ(st.triangles, 2u);
  EXPECT_EQ(st.meshes, 1u);
  EXPECT_FLOAT_EQ(st.hi.x, 3.f);
}

TEST(JsonLoader, TexturesOnMaterialsShapesAndEnvironment) {
  TempDir dir("tex");
  std::vector<float> px = {0.f, 0.5f, 1.f, 0.25f, 0.25f, 0.25f};
  write_image(dir.file("a.exr"), px, 2, 1);
  write_image(dir.file("sky.exr"), px, 2, 1);
  std::string path = dir.write("t.json", R"({"camera": {}, "materials": {
      "wood": {"type": "diffuse", "reflectance": {"texture": "a.exr", "scale": 0.5}, "normal_map": "a.exr"},
      "clamped": {"type": "diffuse", "reflectance": {"texture": "a.exr", "wrap": "clamp", "uv_scale": 2}},
      "metal": {"type": "conductor", "roughness": {"texture": "a.exr", "scale": 0.3}},
      "pbr": {"type": "metallic_roughness", "base_color": "a.exr", "roughness": {"texture": "a.exr"}, "metallic": 1,
              "absorption": [0.1, 0.2, 0.3]},
      "glass": {"type": "dielectric", "absorption": 0.5}},
    "shapes": [{"type": "rectangle", "material": "wood", "emission": {"texture": "a.exr", "scale": [1, 2, 3]}}],
    "lights": [{"type": "environment", "file": "sky.exr", "scale": 2,
                "transform": {"rotate": {"axis": [0, 1, 0], "angle": 90}}}]})");
  SceneDesc d = load_json_scene_file(path);
  const Material& wood = d.materials[0];
  EXPECT_EQ(wood.tex_color, 0);
  EXPECT_FLOAT_EQ(wood.diffuse.x, 0.5f);
  EXPECT_EQ(wood.tex_normal, 1);  // the same file as data (not sRGB): its own texture
  EXPECT_TRUE(d.textures[0].srgb);
  EXPECT_FALSE(d.textures[1].srgb);
  // Other sampler settings on the same image: a copy with those settings.
  const Material& clamped = d.materials[1];
  EXPECT_EQ(clamped.tex_color, 2);
  EXPECT_EQ(int(d.textures[2].wrap_u), int(TexWrap::kClamp));
  EXPECT_EQ(int(d.textures[2].wrap_v), int(TexWrap::kClamp));
  EXPECT_EQ(d.textures[2].uv_scale.x, 2.f);
  EXPECT_EQ(int(d.textures[0].wrap_u), int(TexWrap::kRepeat));
  EXPECT_EQ(int(d.textures[0].wrap_v), int(TexWrap::kRepeat));
  EXPECT_EQ(d.materials[2].type, MaterialType::kRoughConductor);
  EXPECT_EQ(d.materials[2].tex_roughness, 1);
  EXPECT_FLOAT_EQ(d.materials[2].alpha_x, 0.3f);
  EXPECT_EQ(d.materials[3].type, MaterialType::kMetallicRoughness);
  EXPECT_EQ(d.materials[3].tex_color, 0);
  EXPECT_EQ(d.materials[3].tex_roughness, 1);
  EXPECT_FLOAT_EQ(d.materials[3].alpha_x, 1.f);
  EXPECT_FLOAT_EQ(d.materials[3].absorption.z, 0.3f);
  EXPECT_FLOAT_EQ(d.materials[4].absorption.y, 0.5f);
  EXPECT_EQ(d.shapes[0].emission_texture, 0);
  EXPECT_FLOAT_EQ(d.shapes[0].emission.z, 3.f);
  ASSERT_EQ(d.lights.size(), 1u);
  EXPECT_GE(d.lights[0].texture, 0);
  EXPECT_FLOAT_EQ(d.lights[0].L.x, 2.f);
  EXPECT_NEAR(d.environment_to_world.m[0][2], 1.f, 1e-6f);
  EXPECT_EQ(d.textures[d.lights[0].texture].width, 2);
  EXPECT_FLOAT_EQ(d.textures[d.lights[0].texture].rgba[2], 1.f);
}

TEST(JsonLoader, ErrorsNameTheFileAndJsonPath) {
  struct Case {
    std::string text, message;
  };
  std::vector<Case> cases = {
      {scene_with(R"("meshes": {"m": {"positions": [[0,0,0]], "indices": [0, 0, 1]}})"),
       "s.json: /meshes/m/indices/2: vertex index 1 out of range (1 positions)"},
      {scene_with("", R"({"type": "mesh", "mesh": "nope"})"),
       "s.json: /shapes/0/mesh: no mesh named 'nope' in /meshes (meshes: none)"},
      {scene_with("", R"({"type": "mesh"})"),
       "s.json: /shapes/0: a mesh needs inline 'positions' and 'indices', a 'file' or a 'mesh' name from /meshes"},
      {scene_with("", R"({"type": "mesh", "file": "a.obj", "mesh": "x"})"),
       "s.json: /shapes/0: give one of inline 'positions'/'indices', 'file' or 'mesh'"},
      {scene_with("", R"({"type": "mesh", "file": "bunny.stl"})"),
       "s.json: /shapes/0/file: unsupported mesh file 'bunny.stl' (allowed: .obj, .ply)"},
      {scene_with("", R"({"type": "cube", "radius": 2})"),
       "s.json: /shapes/0/radius: unknown key (allowed: name, type, material, emission, emission_two_sided, "
       "flip_normals, transform, interior, exterior)"},
      {scene_with("", R"({"type": "mesh", "positions": [[0,0,0],[1,0,0],[0,1,0]], "indices": [0,1,2], "uvs": [[0,0]]})"),
       "s.json: /shapes/0/uvs: expected one [u,v] per position"},
      {scene_with(R"("materials": {"m": {"type": "diffuse", "normal_map": "a.png", "bump_map": "b.png"}})"),
       "s.json: /materials/m/bump_map: give normal_map or bump_map, not both"},
      {scene_with(R"("materials": {"m": {"type": "metallic_roughness", "sheen_color": [1, 2, 0]}})"),
       "s.json: /materials/m/sheen_color: expected colour values in [0, 1]"},
      {scene_with(R"("materials": {"m": {"type": "metallic_roughness", "specular": -0.5}})"),
       "s.json: /materials/m/specular: expected a number in [0, 1]"},
      {scene_with(R"("materials": {"m": {"type": "metallic_roughness", "clearcoat": 1.2}})"),
       "s.json: /materials/m/clearcoat: expected a number in [0, 1]"},
      {scene_with(R"("materials": {"m": {"type": "metallic_roughness", "clearcoat_roughness": {"texture": "a.png", "scale": -1}}})"),
       "s.json: /materials/m/clearcoat_roughness/scale: expected a number in [0, 1]"},
      {scene_with(R"("materials": {"m": {"type": "metallic_roughness", "clearcoat": {"scale": 1}}})"),
       "s.json: /materials/m/clearcoat: expected a number in [0, 1] or a texture ({\"texture\": file, \"scale\": s})"},
      {scene_with(R"("materials": {"m": {"type": "conductor", "roughness": 0.2, "anisotropy_texture": "a.png"}})"),
       "s.json: /materials/m/anisotropy_texture: needs anisotropic roughness ([alpha_x, alpha_y] with alpha_x != alpha_y)"},
      {scene_with("", R"({"type": "mesh", "positions": [[0,0,0],[1,0,0],[0,1,0]], "indices": [0,1,2], "tangents": [[1,0,0,1]]})"),
       "s.json: /shapes/0/tangents: expected one tangent [tx,ty,tz,w] per position"},
      {scene_with("", R"({"type": "mesh", "positions": [[0,0,0],[1,0,0],[0,1,0]], "indices": [0,1,2],
                          "tangents": [[1,0,0,1],[1,0,0,0.5],[1,0,0,1]]})"),
       "s.json: /shapes/0/tangents/1/3: expected the handedness 1 or -1 (or [0,0,0,0]: no tangent)"},
      {scene_with("", R"({"type": "mesh", "positions": [[0,0,0],[1,0,0],[0,1,0]], "indices": [0,1,2],
                          "tangents": [[1,0,0,1],[1,0,0,1],[0,0,0,-1]]})"),
       "s.json: /shapes/0/tangents/2: expected a non-zero tangent"},
      {scene_with("", R"({"type": "mesh", "positions": [[0,0,0],[1,0,0],[0,1,0]], "indices": [0,1,2],
                          "tangents": [[1,0,0,1],[1,0,0,1],[1,0,0]]})"),
       "s.json: /shapes/0/tangents/2: expected an array of 4 numbers [tx,ty,tz,w]"},
      {scene_with("", R"({"type": "cube", "transform": {"look_at": {"origin": [0,0,0], "target": [0,0,0]}}})"),
       "s.json: /shapes/0/transform/look_at/target: must differ from the origin"},
      {scene_with("", R"({"type": "cube", "transform": {"look_at": {"origin": [0,0,0], "target": [0,1,0]}}})"),
       "s.json: /shapes/0/transform/look_at/up: must not be parallel to the direction from origin to target"},
      {scene_with("", R"({"type": "cube", "transform": [{"scale": 2}, {"translate": [1, 0]}]})"),
       "s.json: /shapes/0/transform/1/translate: expected an array of 3 numbers"},
      {scene_with("", R"({"type": "cube", "transform": {"scale": 2, "look_at": {}}})"),
       "s.json: /shapes/0/transform: 'look_at' cannot be combined with other keys (use a list of steps)"},
      {scene_with("", R"({"type": "cube", "transform": {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,1]}})"),
       "s.json: /shapes/0/transform/matrix: expected an affine matrix (last row 0, 0, 0, 1)"},
      {scene_with("", R"({"type": "cube", "transform": "up"})"),
       "s.json: /shapes/0/transform: expected an object or a list of steps, got string"},
      {scene_with(R"("materials": {"m": {"type": "diffuse", "reflectance": {"file": "x.png"}}})"),
       "s.json: /materials/m/reflectance: expected a colour (a number or [r, g, b]) or a texture ({\"texture\": file})"},
      {scene_with(R"("materials": {"m": {"type": "diffuse", "reflectance": {"texture": "missing.png"}}})"),
       "s.json: /materials/m/reflectance/texture: texture file 'missing.png' does not exist"},
      {scene_with(R"("materials": {"m": {"type": "diffuse", "reflectance": {"texture": "x.png", "wrap": "loop"}}})"),
       "s.json: /materials/m/reflectance/wrap: unknown wrap mode 'loop' (allowed: repeat, clamp, mirror)"},
      {scene_with(R"("materials": {"m": {"type": "diffuse", "normal_map": 1}})"),
       "s.json: /materials/m/normal_map: expected a texture (a file name or {\"texture\": file, \"scale\": s})"},
      {scene_with(R"("materials": {"m": {"type": "metallic_roughness", "metallic": 2}})"),
       "s.json: /materials/m/metallic: expected a number in [0, 1]"},
      {scene_with(R"("materials": {"m": {"type": "metallic_roughness", "roughness": 0.5, "alpha": 0.25}})"),
       "s.json: /materials/m/roughness: give 'roughness' or 'alpha', not both"},
      {scene_with(R"("materials": {"m": {"type": "dielectric", "absorption": -1}})"),
       "s.json: /materials/m/absorption: expected non-negative colour values"},
      {scene_with(R"("materials": {"m": {"type": "conductor", "roughness": [0.1]}})"),
       "s.json: /materials/m/roughness: expected a number or an array of 2 numbers"},
      {scene_with(R"("materials": {"m": {"type": "velvet"}})"),
       "s.json: /materials/m/type: unknown material type 'velvet' (allowed: diffuse, conductor, dielectric, "
       "thindielectric, plastic, difftrans, phong, metallic_roughness, principled, blend, two_sided, null)"},
      {scene_with(R"("lights": [{"type": "environment", "file": "sky.hdr", "radiance": 1}])"),
       "s.json: /lights/0/radiance: give 'radiance' (constant) or 'file' and 'scale', not both"},
      {scene_with(R"("lights": [{"type": "environment", "file": "sky.hdr"}])"),
       "s.json: /lights/0/file: texture file 'sky.hdr' does not exist"},
      {scene_with(R"("lights": [{"type": "environment", "transform": {"scale": 1}}])"),
       "s.json: /lights/0/transform: 'transform' goes with 'file' (a constant environment has no orientation)"},
      {scene_with(R"("lights": [{"type": "environment"}, {"type": "environment"}])"),
       "s.json: /lights/1: at most one environment light (the first is /lights/0)"},
      {scene_with(R"("lights": [{"type": "spot", "target": [0, 0, 0], "direction": [0, -1, 0]}])"),
       "s.json: /lights/0: give 'target' or 'direction', not both"},
      {scene_with(R"("film": {"width": 0})"), "s.json: /film/width: expected a positive integer"},
      {scene_with(R"("film": {"filter": "box"}, "filter": "box")"), "s.json: /filter: give the filter once (here or in /film)"},
      {scene_with(R"("integrator": {"type": "mlt"})"),
       "s.json: /integrator/type: unknown integrator 'mlt' (allowed: path, sppm, ppm, pppm, pm, light, bdpt, bpm, vcm, "
       "upg, restir)"},
      {scene_with(R"("integrator": {"spp": 0})"), "s.json: /integrator/spp: expected a positive integer"},
      {scene_with(R"("integrator": {"alpha": 1.5})"), "s.json: /integrator/alpha: expected a number in (0, 1)"},
      {scene_with(R"("integrator": {"sampler": "halton"})"),
       "s.json: /integrator/sampler: unknown sampler 'halton' (allowed: sobol, independent)"},
      {scene_with(R"("integrator": {"max_depth": 4}, "max_depth": 4)"),
       "s.json: /integrator/max_depth: give max_depth once (here or at /max_depth)"},
      {scene_with(R"("integrator": {"seed": 4})"),
       "s.json: /integrator/seed: unknown key (allowed: type, spp, time, max_depth, rr_depth, sampler, photons, radius, "
       "alpha, k, photon_sampling, restir_candidates, restir_neighbors, restir_radius, restir_history, light_sampler, "
       "hide_emitters)"},
      {scene_with(R"("integrator": {"hide_emitters": 1})"),
       "s.json: /integrator/hide_emitters: expected true or false, got number"},
      {scene_with(R"("integrator": {"photon_sampling": "smart"})"),
       "s.json: /integrator/photon_sampling: unknown photon sampling 'smart' (allowed: uniform, adaptive)"},
      {R"({"camera": "top", "cameras": {"front": {}, "side": {"position": [1, 0, 0]}}, "shapes": [{"type": "cube"}]})",
       "s.json: /camera: no camera named 'top' in /cameras (cameras: front, side)"},
      {R"({"cameras": {"front": {"name": "x"}}, "shapes": [{"type": "cube"}]})",
       "s.json: /cameras/front/name: a named camera takes its name from its key"},
      {R"({"shapes": [{"type": "cube"}]})", "s.json: /camera: missing (a scene needs a camera, or named cameras in /cameras)"},
  };
  for (const Case& c : cases) EXPECT_EQ(error_of(c.text), c.message) << c.text;
}

TEST(JsonLoader, MissingMeshFileNamesBothFiles) {
  TempDir dir("missing");
  std::string path = dir.write("scene.json", scene_with("", R"({"type": "mesh", "file": "meshes/bunny.ply"})"));
  try {
    load_json_scene_file(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": /shapes/0/file: mesh file 'meshes/bunny.ply' does not exist (looked for " +
                                         dir.file("meshes/bunny.ply") + ")");
  }
  std::string path2 = dir.write("named.json", scene_with(R"("meshes": {"b": {"file": "b.obj"}})"));
  try {
    load_json_scene_file(path2);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path2 + ": /meshes/b/file: mesh file 'b.obj' does not exist (looked for " +
                                         dir.file("b.obj") + ")");
  }
}

TEST(JsonLoader, MeshFilesThroughTheMeshLoaders) {
  TempDir dir("files");
  dir.write("quad.ply",
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
  dir.write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  std::string path = dir.write("m.json", scene_with(R"("meshes": {"q": {"file": "quad.ply"}, "t": {"file": "tri.obj"}},
      "materials": {"red": {"type": "diffuse", "reflectance": [1, 0, 0]}})",
                                                     R"({"type": "mesh", "file": "quad.ply", "name": "direct"},
      {"type": "mesh", "mesh": "q", "material": "red"}, {"type": "mesh", "mesh": "t", "material": "red"},
      {"type": "mesh", "file": "tri.obj", "material": "red", "transform": {"translate": [0, 0, 1]}})"));
  SceneDesc d = load_json_scene_file(path);
  SceneStats st = scene_stats(d);
  EXPECT_EQ(st.triangles, 2u + 2u + 1u + 1u);
  EXPECT_EQ(d.shapes.size(), 4u);
  EXPECT_EQ(d.shapes[0].name, "direct");
  EXPECT_EQ(d.material_names[d.shapes[1].material], "red");
  EXPECT_EQ(d.material_names[d.shapes[3].material], "red");
  EXPECT_FLOAT_EQ(d.shapes[3].to_world.m[2][3], 1.f);
}

TEST(JsonLoader, InvalidJsonIsOneLineWithItsLine) {
  EXPECT_EQ(error_of("{\n  \"name\": \"x\",\n  \"shapes\": [,]\n}"),
            "s.json:3: invalid JSON: syntax error while parsing value - unexpected ','; expected '[', '{', or a literal");
  // A number too large for a double (a fuzzer finding: it escaped as the JSON library's exception).
  EXPECT_EQ(error_of("{\n  \"name\": \"x\",\n  \"max_depth\": 3e983\n}"),
            "s.json:3: invalid JSON: number overflow parsing '3e983'");
}
