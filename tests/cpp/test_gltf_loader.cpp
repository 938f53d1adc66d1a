// glTF 2.0 / GLB loader: files are generated here (JSON + binary buffers,
// PNG images from stb_image_write) into a temporary folder and loaded; the
// resulting SceneDesc is checked, and every malformed input gets its exact
// message checked.
#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#include <gtest/gtest.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "caustica/base/error.h"
#include "caustica/scene/load.h"
#include "caustica/scene/loaders/gltf_loader.h"

extern "C" unsigned char* stbi_write_png_to_mem(const unsigned char* pixels, int stride_bytes, int x, int y, int n,
                                                int* out_len);

using namespace caustica;
using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("caustica_gltf_test_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

std::string base64(const std::vector<unsigned char>& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    uint32_t v = in[i] << 16 | in[i + 1] << 8 | in[i + 2];
    for (int k = 3; k >= 0; --k) out += t[(v >> (6 * k)) & 63];
  }
  if (i + 1 == in.size()) {
    uint32_t v = in[i] << 16;
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == in.size()) {
    uint32_t v = in[i] << 16 | in[i + 1] << 8;
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += t[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

std::vector<unsigned char> png(int w, int h, const std::vector<unsigned char>& rgb, int channels = 3) {
  int len = 0;
  unsigned char* p = stbi_write_png_to_mem(rgb.data(), w * channels, w, h, channels, &len);
  std::vector<unsigned char> out(p, p + len);
  free(p);
  return out;
}

// Builds a glTF document with one binary buffer.
struct Builder {
  json j = {{"asset", {{"version", "2.0"}}}};
  std::vector<unsigned char> bin;

  int push(const char* key, json v) {
    j[key].push_back(std::move(v));
    return int(j[key].size()) - 1;
  }
  int view(const void* data, size_t n) {
    while (bin.size() % 4) bin.push_back(0);
    size_t off = bin.size();
    bin.insert(bin.end(), (const unsigned char*)data, (const unsigned char*)data + n);
    return push("bufferViews", {{"buffer", 0}, {"byteOffset", off}, {"byteLength", n}});
  }
  int floats(const std::vector<float>& v, const char* type, int ncomp) {
    int bv = view(v.data(), v.size() * 4);
    return push("accessors", {{"bufferView", bv}, {"componentType", 5126}, {"count", v.size() / ncomp}, {"type", type}});
  }
  template <typename T>
  int indices(const std::vector<T>& v) {
    int bv = view(v.data(), v.size() * sizeof(T));
    int ct = sizeof(T) == 1 ? 5121 : sizeof(T) == 2 ? 5123 : 5125;
    return push("accessors", {{"bufferView", bv}, {"componentType", ct}, {"count", v.size()}, {"type", "SCALAR"}});
  }
  // A unit quad in the xy plane ([-1,1]^2, facing +z) with UVs (glTF: v = 0 at the top).
  int quad(json material = nullptr, float half = 1.f) {
    int pos = floats({-half, -half, 0, half, -half, 0, half, half, 0, -half, half, 0}, "VEC3", 3);
    int nor = floats({0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1}, "VEC3", 3);
    int uv = floats({0, 1, 1, 1, 1, 0, 0, 0}, "VEC2", 2);
    int ind = indices(std::vector<uint16_t>{0, 1, 2, 0, 2, 3});
    json prim = {{"attributes", {{"POSITION", pos}, {"NORMAL", nor}, {"TEXCOORD_0", uv}}}, {"indices", ind}};
    if (!material.is_null()) prim["material"] = material;
    return push("meshes", {{"primitives", json::array({prim})}});
  }
  void scene(std::vector<int> roots) { j["scenes"] = json::array({{{"nodes", roots}}}); j["scene"] = 0; }
  void finish_buffer(const std::string& uri) {  // buffer 0 (any others stay)
    json b = {{"byteLength", bin.size()}};
    if (!uri.empty()) b["uri"] = uri;
    if (!j.contains("buffers") || j["buffers"].empty()) j["buffers"] = json::array({b});
    else j["buffers"][0] = b;
  }
  // .gltf with the buffer in NAME.bin next to it.
  std::string write(const std::string& name) {
    fs::path d = temp_dir();
    if (!bin.empty()) {
      std::ofstream(d / (name + ".bin"), std::ios::binary).write((const char*)bin.data(), bin.size());
      finish_buffer(name + ".bin");
    }
    std::ofstream(d / (name + ".gltf")) << j.dump(2);
    return (d / (name + ".gltf")).string();
  }
  // .gltf with the buffer as a base64 data URI.
  std::string write_data_uri(const std::string& name) {
    finish_buffer("data:application/octet-stream;base64," + base64(bin));
    fs::path p = temp_dir() / (name + ".gltf");
    std::ofstream(p) << j.dump();
    return p.string();
  }
  std::string write_glb(const std::string& name) {
    if (!bin.empty()) finish_buffer("");
    std::string js = j.dump();
    while (js.size() % 4) js += ' ';
    while (bin.size() % 4) bin.push_back(0);
    std::vector<unsigned char> out;
    auto u32 = [&](uint32_t v) { for (int k = 0; k < 4; ++k) out.push_back((v >> (8 * k)) & 255); };
    uint32_t total = 12 + 8 + uint32_t(js.size()) + (bin.empty() ? 0 : 8 + uint32_t(bin.size()));
    out.insert(out.end(), {'g', 'l', 'T', 'F'});
    u32(2);
    u32(total);
    u32(uint32_t(js.size()));
    u32(0x4E4F534A);
    out.insert(out.end(), js.begin(), js.end());
    if (!bin.empty()) {
      u32(uint32_t(bin.size()));
      u32(0x004E4942);
      out.insert(out.end(), bin.begin(), bin.end());
    }
    fs::path p = temp_dir() / (name + ".glb");
    std::ofstream(p, std::ios::binary).write((const char*)out.data(), out.size());
    return p.string();
  }
};

std::string write_text(const std::string& name, const std::string& text) {
  fs::path p = temp_dir() / name;
  std::ofstream(p) << text;
  return p.string();
}

std::string error_of(const std::string& path) {
  try {
    load_gltf_scene(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

void expect_near(Vec3f a, Vec3f b, float tol = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

bool has_warning(const SceneDesc& d, const std::string& needle) {
  for (const std::string& w : d.warnings)
    if (w.find(needle) != std::string::npos) return true;
  return false;
}

}  // namespace

TEST(GltfLoader, NodeTransformsAndInstancing) {
  Builder b;
  int mesh = b.quad();
  const float s45 = std::sqrt(0.5f);
  int child = b.push("nodes", {{"mesh", mesh}, {"translation", {1, 0, 0}}});
  int parent = b.push("nodes", {{"children", {child}}, {"translation", {1, 2, 3}},
                                {"rotation", {0, 0, s45, s45}}, {"scale", {2, 2, 2}}});
  // The same mesh again through a column-major matrix: translate (5, 0, 0).
  int other = b.push("nodes", {{"mesh", mesh}, {"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 5, 0, 0, 1}}});
  b.scene({parent, other});
  SceneDesc d = load_gltf_scene(b.write("transforms"));
  ASSERT_EQ(d.meshes.size(), 1u);  // one mesh, two instances
  ASSERT_EQ(d.shapes.size(), 2u);
  EXPECT_EQ(d.shapes[0].mesh, 0);
  EXPECT_EQ(d.shapes[1].mesh, 0);
  // Vertex (-1,-1,0): child (0,-1,0) -> scale (0,-2,0) -> rotate 90 deg about z (2,0,0) -> + (1,2,3).
  expect_near(d.shapes[0].to_world.point(d.meshes[0].positions[0]), Vec3f(3, 2, 3));
  expect_near(d.shapes[0].to_world.point(Vec3f(0, 0, 0)), Vec3f(1, 4, 3));
  expect_near(d.shapes[1].to_world.point(d.meshes[0].positions[0]), Vec3f(4, -1, 0));
  // UVs are flipped to caustica's convention (v = 0 at the bottom of the image).
  EXPECT_FLOAT_EQ(d.meshes[0].uvs[0].y, 0.f);
  EXPECT_FLOAT_EQ(d.meshes[0].uvs[2].y, 1.f);
  EXPECT_EQ(d.meshes[0].indices.size(), 6u);
  // No camera or light in the file: defaults, each reported.
  EXPECT_TRUE(has_warning(d, "no camera in the file"));
  EXPECT_TRUE(has_warning(d, "no lights in the file"));
  SceneStats st = scene_stats(d);
  EXPECT_EQ(st.meshes, 1u);
  EXPECT_EQ(st.shapes, 2u);
  EXPECT_EQ(st.triangles, 4u);
}

TEST(GltfLoader, CamerasDefaultAndByName) {
  Builder b;
  int mesh = b.quad();
  b.push("cameras", {{"type", "perspective"}, {"name", "front"},
                     {"perspective", {{"yfov", 0.5}, {"znear", 0.1}, {"aspectRatio", 1.5}}}});
  b.push("cameras", {{"type", "perspective"}, {"perspective", {{"yfov", 1.0}, {"znear", 0.1}, {"zfar", 50}}}});
  b.push("cameras", {{"type", "orthographic"}, {"orthographic", {{"xmag", 1}, {"ymag", 1}, {"zfar", 10}, {"znear", 0}}}});
  const float s45 = std::sqrt(0.5f);
  int n0 = b.push("nodes", {{"mesh", mesh}});
  int n1 = b.push("nodes", {{"camera", 1}, {"translation", {4, 0, 0}}, {"rotation", {0, s45, 0, s45}},
                            {"scale", {2, 2, 2}}});  // looks down -x; twice the size
  int n2 = b.push("nodes", {{"camera", 0}, {"translation", {0, 0, 5}}});
  int n3 = b.push("nodes", {{"camera", 2}});
  b.scene({n0, n1, n2, n3});
  std::string path = b.write("cameras");
  SceneDesc d = load_gltf_scene(path);
  ASSERT_EQ(d.cameras.size(), 3u);
  EXPECT_EQ(d.cameras[0].name, "front");  // the first glTF camera is the default
  EXPECT_EQ(d.cameras[1].name, "camera1");
  EXPECT_EQ(d.camera.name, "front");
  expect_near(d.camera.position, Vec3f(0, 0, 5));
  expect_near(d.camera.target, Vec3f(0, 0, 4));
  expect_near(d.camera.up, Vec3f(0, 1, 0));
  EXPECT_NEAR(d.camera.fov_degrees, 0.5f * 180.f / 3.14159265f, 1e-4f);
  EXPECT_EQ(d.camera.fov_axis, CameraDesc::FovAxis::kY);
  EXPECT_EQ(d.camera.width, 768);
  EXPECT_EQ(d.camera.height, 512);
  expect_near(d.cameras[1].target - d.cameras[1].position, Vec3f(-1, 0, 0));
  // The orthographic camera: xmag, ymag are half the view's width and height.
  EXPECT_EQ(d.cameras[2].name, "camera2");
  EXPECT_TRUE(d.cameras[2].orthographic);
  EXPECT_FALSE(d.cameras[0].orthographic);
  EXPECT_FLOAT_EQ(d.cameras[2].view_size, 2.f);
  EXPECT_EQ(d.cameras[2].fov_axis, CameraDesc::FovAxis::kY);
  EXPECT_EQ(d.cameras[2].width, 512);
  EXPECT_FALSE(has_warning(d, "orthographic"));
  EXPECT_FALSE(has_warning(d, "no camera in the file"));
  // znear and zfar are the clipping planes (a perspective camera's zfar is optional: infinity), in the node's scale.
  EXPECT_FLOAT_EQ(d.cameras[0].near_clip, 0.1f);
  EXPECT_EQ(d.cameras[0].far_clip, kInf);
  EXPECT_NEAR(d.cameras[1].near_clip, 0.2f, 1e-6f);
  EXPECT_NEAR(d.cameras[1].far_clip, 100.f, 1e-4f);
  EXPECT_EQ(d.cameras[2].near_clip, 0.f);
  EXPECT_FLOAT_EQ(d.cameras[2].far_clip, 10.f);
  LoadOptions opt;
  opt.camera = "camera1";
  SceneDesc d2 = load_scene_desc(path, opt);
  expect_near(d2.camera.position, Vec3f(4, 0, 0));
  opt.camera = "nope";
  try {
    load_scene_desc(path, opt);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "cameras: no camera named 'nope' (cameras: front, camera1, camera2)");
  }
}

TEST(GltfLoader, PunctualLights) {
  Builder b;
  int mesh = b.quad();
  b.j["extensionsUsed"] = {"KHR_lights_punctual"};
  b.j["extensions"]["KHR_lights_punctual"]["lights"] = {
      {{"type", "point"}, {"intensity", 683.0 * 2}, {"color", {1, 0.5, 0.25}}},
      {{"type", "spot"}, {"intensity", 683.0}, {"spot", {{"innerConeAngle", 0.2}, {"outerConeAngle", 0.5}}}},
      {{"type", "directional"}, {"intensity", 683.0 * 3}}};
  const float s45 = std::sqrt(0.5f);
  int m = b.push("nodes", {{"mesh", mesh}});
  int p = b.push("nodes", {{"translation", {1, 2, 3}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
  int s = b.push("nodes", {{"translation", {0, 4, 0}}, {"rotation", {-s45, 0, 0, s45}},  // -z -> -y
                           {"extensions", {{"KHR_lights_punctual", {{"light", 1}}}}}});
  int dl = b.push("nodes", {{"rotation", {0, s45, 0, s45}}, {"extensions", {{"KHR_lights_punctual", {{"light", 2}}}}}});
  b.scene({m, p, s, dl});
  SceneDesc d = load_gltf_scene(b.write("lights"));
  ASSERT_EQ(d.lights.size(), 3u);  // no default environment: the file has lights
  EXPECT_EQ(d.lights[0].type, LightType::kPoint);
  expect_near(d.lights[0].L, RGB(2, 1, 0.5f));  // candela / 683
  expect_near(d.lights[0].p, Vec3f(1, 2, 3));
  EXPECT_EQ(d.lights[1].type, LightType::kSpot);
  expect_near(d.lights[1].p, Vec3f(0, 4, 0));
  expect_near(d.lights[1].dir, Vec3f(0, -1, 0));
  EXPECT_NEAR(d.lights[1].cos_total, std::cos(0.5f), 1e-6f);
  EXPECT_NEAR(d.lights[1].cos_falloff_start, std::cos(0.2f), 1e-6f);
  EXPECT_EQ(d.lights[2].type, LightType::kDirectional);
  expect_near(d.lights[2].dir, Vec3f(-1, 0, 0));
  expect_near(d.lights[2].L, RGB(3.f));
  EXPECT_FALSE(has_warning(d, "no lights"));
}

TEST(GltfLoader, MaterialsTransmissionVolumeEmission) {
  Builder b;
  b.j["extensionsUsed"] = {"KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                           "KHR_materials_emissive_strength", "KHR_materials_dispersion", "EXT_made_up"};
  b.push("materials", {{"name", "glass"},
                       {"pbrMetallicRoughness", {{"baseColorFactor", {0.9, 0.8, 0.7, 1}}, {"metallicFactor", 0.0},
                                                 {"roughnessFactor", 0.1}}},
                       {"extensions",
                        {{"KHR_materials_transmission", {{"transmissionFactor", 1.0}}},
                         {"KHR_materials_ior", {{"ior", 1.33}}},
                         {"KHR_materials_volume",
                          {{"thicknessFactor", 1.0}, {"attenuationDistance", 2.0}, {"attenuationColor", {0.5, 1.0, 0.25}}}}}}});
  b.push("materials", {{"name", "lamp"}, {"emissiveFactor", {1, 1, 1}}, {"doubleSided", true},
                       {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 5.0}}}}}});
  int glass = b.quad(0), lamp = b.quad(1);
  int n0 = b.push("nodes", {{"mesh", glass}});
  int n1 = b.push("nodes", {{"mesh", lamp}, {"translation", {0, 0, 2}}});
  b.scene({n0, n1});
  SceneDesc d = load_gltf_scene(b.write("materials"));
  ASSERT_EQ(d.materials.size(), 2u);
  const Material& g = d.materials[0];
  EXPECT_EQ(d.material_names[0], "glass");
  EXPECT_EQ(g.type, MaterialType::kMetallicRoughness);
  EXPECT_FLOAT_EQ(g.transmission_weight, 1.f);
  EXPECT_FLOAT_EQ(g.eta, 1.33f);
  EXPECT_FLOAT_EQ(g.metallic, 0.f);
  EXPECT_NEAR(g.alpha_x, 0.01f, 1e-6f);  // GGX alpha = roughness^2
  expect_near(g.absorption, RGB(-std::log(0.5f) / 2, 0.f, -std::log(0.25f) / 2));
  EXPECT_EQ(g.flags & kTwoSided, 0u);
  EXPECT_NE(d.materials[1].flags & kTwoSided, 0u);
  ASSERT_EQ(d.shapes.size(), 2u);
  expect_near(d.shapes[0].emission, RGB(0.f));
  expect_near(d.shapes[1].emission, RGB(5.f));  // emissiveFactor * emissiveStrength
  EXPECT_TRUE(d.shapes[1].emission_two_sided);
  EXPECT_TRUE(has_warning(d, "extension KHR_materials_dispersion is not supported; its properties are ignored"));
  EXPECT_TRUE(has_warning(d, "unknown extension EXT_made_up ignored"));
  EXPECT_FALSE(has_warning(d, "no lights"));  // the emissive quad is an area light
}

TEST(GltfLoader, Clearcoat) {
  // KHR_materials_clearcoat: the factor and the roughness (alpha = roughness^2), their textures (linear), the
  // coat's normal texture and its scale; no coat without the extension or with factor 0 (its textures unused
  // then).
  Builder b;
  b.j["extensionsUsed"] = {"KHR_materials_clearcoat"};
  b.push("images", {{"uri", "data:image/png;base64," + base64(png(1, 1, {200, 100, 50}))}});
  b.push("textures", {{"source", 0}});
  b.push("materials", {{"name", "paint"},
                       {"extensions",
                        {{"KHR_materials_clearcoat",
                          {{"clearcoatFactor", 0.8}, {"clearcoatRoughnessFactor", 0.3}, {"clearcoatTexture", {{"index", 0}}},
                           {"clearcoatRoughnessTexture", {{"index", 0}}}, {"clearcoatNormalTexture", {{"index", 0}, {"scale", 0.5}}}}}}}});
  b.push("materials", {{"name", "plain"}});
  b.push("materials", {{"name", "off"},
                       {"extensions", {{"KHR_materials_clearcoat", {{"clearcoatTexture", {{"index", 0}}}}}}}});
  int q0 = b.quad(0), q1 = b.quad(1), q2 = b.quad(2);
  b.scene({b.push("nodes", {{"mesh", q0}}), b.push("nodes", {{"mesh", q1}}), b.push("nodes", {{"mesh", q2}})});
  SceneDesc d = load_gltf_scene(b.write("clearcoat"));
  ASSERT_EQ(d.materials.size(), 3u);
  const Material& m = d.materials[0];
  EXPECT_FLOAT_EQ(m.clearcoat, 0.8f);
  EXPECT_NEAR(m.clearcoat_alpha, 0.09f, 1e-7f);
  ASSERT_GE(m.tex_clearcoat, 0);
  EXPECT_EQ(m.tex_clearcoat_roughness, m.tex_clearcoat);  // one image, both linear: decoded once
  EXPECT_FALSE(d.textures[size_t(m.tex_clearcoat)].srgb);
  EXPECT_NEAR(d.textures[size_t(m.tex_clearcoat)].rgba[0], 200.f / 255.f, 1e-6f);
  EXPECT_EQ(m.tex_clearcoat_normal, m.tex_clearcoat);  // linear too
  EXPECT_FLOAT_EQ(m.clearcoat_normal_scale, 0.5f);
  EXPECT_EQ(m.tex_normal, -1);  // the base's normal stays unmapped
  for (const std::string& w : d.warnings) EXPECT_EQ(w.find("clearcoatNormalTexture"), std::string::npos) << w;  // supported
  EXPECT_EQ(d.materials[1].clearcoat, 0.f);
  EXPECT_EQ(d.materials[1].tex_clearcoat_normal, -1);
  EXPECT_EQ(d.materials[1].tex_clearcoat, -1);
  EXPECT_EQ(d.materials[2].clearcoat, 0.f);  // clearcoatFactor defaults to 0: the texture scales nothing
  EXPECT_EQ(d.materials[2].tex_clearcoat, -1);
  EXPECT_EQ(d.materials[2].tex_clearcoat_normal, -1);
  // Bad values name the JSON path.
  Builder e;
  e.push("materials", {{"extensions", {{"KHR_materials_clearcoat", {{"clearcoatRoughnessFactor", 1.5}}}}}});
  e.scene({e.push("nodes", {{"mesh", e.quad(0)}})});
  std::string p = e.write("badcoat");
  EXPECT_EQ(error_of(p), p + ": /materials/0/extensions/KHR_materials_clearcoat/clearcoatRoughnessFactor: expected a "
                             "number in [0, 1]");
  Builder f;
  f.push("materials", {{"extensions", {{"KHR_materials_clearcoat", {{"clearcoatTexture", {{"index", 3}}}}}}}});
  f.scene({f.push("nodes", {{"mesh", f.quad(0)}})});
  p = f.write("badcoattex");
  EXPECT_NE(error_of(p).find("/materials/0/extensions/KHR_materials_clearcoat/clearcoatTexture/index"), std::string::npos)
      << error_of(p);
}

TEST(GltfLoader, Specular) {
  // KHR_materials_specular: specularFactor (default 1) and specularColorFactor (default white, may exceed 1);
  // specularTexture's alpha becomes the red of a linear copy (the slot reads red), made once for two
  // materials; specularColorTexture is sRGB.
  Builder b;
  b.j["extensionsUsed"] = {"KHR_materials_specular"};
  b.push("images", {{"uri", "data:image/png;base64," + base64(png(1, 1, {255, 0, 0, 51}, 4))}});
  b.push("textures", {{"source", 0}});
  const json ext = {{"specularFactor", 0.5}, {"specularColorFactor", {2.0, 1.0, 0.5}}, {"specularTexture", {{"index", 0}}},
                    {"specularColorTexture", {{"index", 0}}}};
  b.push("materials", {{"extensions", {{"KHR_materials_specular", ext}}}});
  b.push("materials", {{"name", "again"}, {"extensions", {{"KHR_materials_specular", ext}}}});
  b.push("materials", {{"name", "plain"}});
  int q0 = b.quad(0), q1 = b.quad(1), q2 = b.quad(2);
  b.scene({b.push("nodes", {{"mesh", q0}}), b.push("nodes", {{"mesh", q1}}), b.push("nodes", {{"mesh", q2}})});
  SceneDesc d = load_gltf_scene(b.write("specular"));
  ASSERT_EQ(d.materials.size(), 3u);
  const Material& m = d.materials[0];
  EXPECT_FLOAT_EQ(m.specular_weight, 0.5f);
  expect_near(m.specular, RGB(2.f, 1.f, 0.5f));
  ASSERT_GE(m.tex_specular, 0);
  ASSERT_GE(m.tex_specular_color, 0);
  EXPECT_EQ(d.materials[1].tex_specular, m.tex_specular);  // one copy
  const TextureDesc& w = d.textures[size_t(m.tex_specular)];
  EXPECT_FALSE(w.srgb);
  EXPECT_NEAR(w.rgba[0], 0.2f, 1e-6f);  // the alpha 51/255
  EXPECT_FLOAT_EQ(w.rgba[3], 1.f);
  const TextureDesc& col = d.textures[size_t(m.tex_specular_color)];
  EXPECT_TRUE(col.srgb);
  EXPECT_FLOAT_EQ(col.rgba[0], 1.f);
  EXPECT_EQ(d.materials[2].specular_weight, 1.f);
  expect_near(d.materials[2].specular, RGB(1.f));
  EXPECT_FALSE(has_warning(d, "KHR_materials_specular"));
  Builder e;
  e.push("materials", {{"extensions", {{"KHR_materials_specular", {{"specularColorFactor", {1.0, -1.0, 1.0}}}}}}});
  e.scene({e.push("nodes", {{"mesh", e.quad(0)}})});
  std::string p = e.write("badspec");
  EXPECT_EQ(error_of(p), p + ": /materials/0/extensions/KHR_materials_specular/specularColorFactor: expected "
                             "non-negative colour values");
}

TEST(GltfLoader, Iridescence) {
  // KHR_materials_iridescence: weight (times the iridescenceTexture's red), IOR, thickness range (the
  // iridescenceThicknessTexture's green moved to a copy's red, linear); the maximum alone without a texture;
  // defaults 1.3, 100 and 400 nm; no texture is read at weight 0; an IOR below 1 is an error.
  Builder b;
  b.j["extensionsUsed"] = {"KHR_materials_iridescence"};
  b.push("images", {{"uri", "data:image/png;base64," + base64(png(1, 1, {255, 153, 0, 255}, 4))}});
  b.push("textures", {{"source", 0}});
  b.push("materials", {{"extensions", {{"KHR_materials_iridescence",
                                         {{"iridescenceFactor", 0.8}, {"iridescenceIor", 1.6},
                                          {"iridescenceThicknessMinimum", 150}, {"iridescenceThicknessMaximum", 700},
                                          {"iridescenceTexture", {{"index", 0}}},
                                          {"iridescenceThicknessTexture", {{"index", 0}}}}}}}});
  b.push("materials", {{"extensions", {{"KHR_materials_iridescence", {{"iridescenceFactor", 1.0}}}}}});
  b.push("materials", {{"extensions", {{"KHR_materials_iridescence", {{"iridescenceThicknessTexture", {{"index", 0}}}}}}}});
  int q0 = b.quad(0), q1 = b.quad(1), q2 = b.quad(2);
  b.scene({b.push("nodes", {{"mesh", q0}}), b.push("nodes", {{"mesh", q1}}), b.push("nodes", {{"mesh", q2}})});
  SceneDesc d = load_gltf_scene(b.write("film"));
  ASSERT_EQ(d.materials.size(), 3u);
  const Material& m = d.materials[0];
  EXPECT_FLOAT_EQ(m.iridescence, 0.8f);
  EXPECT_FLOAT_EQ(m.iridescence_eta, 1.6f);
  EXPECT_FLOAT_EQ(m.iridescence_thickness, 700.f);
  EXPECT_FLOAT_EQ(m.iridescence_thickness_min, 150.f);
  ASSERT_GE(m.tex_iridescence, 0);
  ASSERT_GE(m.tex_iridescence_thickness, 0);
  EXPECT_FALSE(d.textures[size_t(m.tex_iridescence)].srgb);
  EXPECT_NEAR(d.textures[size_t(m.tex_iridescence)].rgba[0], 1.f, 1e-6f);
  EXPECT_FALSE(d.textures[size_t(m.tex_iridescence_thickness)].srgb);
  EXPECT_NEAR(d.textures[size_t(m.tex_iridescence_thickness)].rgba[0], 0.6f, 1e-6f);  // green 153/255
  const Material& plain = d.materials[1];
  EXPECT_FLOAT_EQ(plain.iridescence, 1.f);
  EXPECT_FLOAT_EQ(plain.iridescence_eta, 1.3f);
  EXPECT_FLOAT_EQ(plain.iridescence_thickness, 400.f);
  EXPECT_EQ(plain.tex_iridescence_thickness, -1);
  EXPECT_FLOAT_EQ(d.materials[2].iridescence, 0.f);
  EXPECT_EQ(d.materials[2].tex_iridescence_thickness, -1);
  Builder e;
  e.push("materials", {{"extensions", {{"KHR_materials_iridescence", {{"iridescenceFactor", 1.0}, {"iridescenceIor", 0.9}}}}}});
  e.scene({e.push("nodes", {{"mesh", e.quad(0)}})});
  std::string p = e.write("badfilm");
  EXPECT_EQ(error_of(p), p + ": /materials/0/extensions/KHR_materials_iridescence/iridescenceIor: expected an index of "
                             "refraction >= 1");
  // Its texture infos are checked as the other extensions' (the fuzzer found one without an index read freed
  // memory).
  Builder t;
  t.push("materials", {{"extensions", {{"KHR_materials_iridescence", {{"iridescenceFactor", 1.0},
                                                                       {"iridescenceThicknessTexture", {{"texCoord", 0}}}}}}}});
  t.scene({t.push("nodes", {{"mesh", t.quad(0)}})});
  p = t.write("badfilmtex");
  EXPECT_NE(error_of(p).find(p + ": /materials/0/extensions/KHR_materials_iridescence/iridescenceThicknessTexture"),
            std::string::npos) << error_of(p);
  // So are KHR_materials_anisotropy's and KHR_materials_pbrSpecularGlossiness's, which were not either.
  for (const char* ext : {"KHR_materials_anisotropy", "KHR_materials_pbrSpecularGlossiness"}) {
    const char* key = std::string(ext) == "KHR_materials_anisotropy" ? "anisotropyTexture" : "diffuseTexture";
    Builder u;
    u.push("materials", {{"extensions", {{ext, {{key, {{"texCoord", 0}}}}}}}});
    u.scene({u.push("nodes", {{"mesh", u.quad(0)}})});
    p = u.write("badtexinfo");
    EXPECT_NE(error_of(p).find(p + ": /materials/0/extensions/" + std::string(ext) + "/" + key + "/index: missing"),
              std::string::npos) << error_of(p);
  }
}

TEST(GltfLoader, Sheen) {
  // KHR_materials_sheen: the colour (sRGB texture) and roughness (its texture's alpha moved to a grey copy's
  // red), the albedo table left to Scene::build; no sheen with a black colour; colours above 1 are errors.
  Builder b;
  b.j["extensionsUsed"] = {"KHR_materials_sheen"};
  b.push("images", {{"uri", "data:image/png;base64," + base64(png(1, 1, {255, 128, 0, 102}, 4))}});
  b.push("textures", {{"source", 0}});
  b.push("materials", {{"extensions", {{"KHR_materials_sheen", {{"sheenColorFactor", {0.9, 0.5, 0.2}}, {"sheenRoughnessFactor", 0.6},
                                                                 {"sheenColorTexture", {{"index", 0}}},
                                                                 {"sheenRoughnessTexture", {{"index", 0}}}}}}}});
  b.push("materials", {{"extensions", {{"KHR_materials_sheen", {{"sheenRoughnessTexture", {{"index", 0}}}}}}}});
  int q0 = b.quad(0), q1 = b.quad(1);
  b.scene({b.push("nodes", {{"mesh", q0}}), b.push("nodes", {{"mesh", q1}})});
  SceneDesc d = load_gltf_scene(b.write("sheen"));
  ASSERT_EQ(d.materials.size(), 2u);
  const Material& m = d.materials[0];
  expect_near(m.sheen_color, RGB(0.9f, 0.5f, 0.2f));
  EXPECT_FLOAT_EQ(m.sheen_roughness, 0.6f);
  ASSERT_GE(m.tex_sheen_color, 0);
  ASSERT_GE(m.tex_sheen_roughness, 0);
  EXPECT_TRUE(d.textures[size_t(m.tex_sheen_color)].srgb);
  EXPECT_FALSE(d.textures[size_t(m.tex_sheen_roughness)].srgb);
  EXPECT_NEAR(d.textures[size_t(m.tex_sheen_roughness)].rgba[0], 0.4f, 1e-6f);  // alpha 102/255
  expect_near(d.materials[1].sheen_color, RGB(0.f));
  EXPECT_EQ(d.materials[1].tex_sheen_roughness, -1);
  Builder e;
  e.push("materials", {{"extensions", {{"KHR_materials_sheen", {{"sheenColorFactor", {1.5, 1.0, 1.0}}}}}}});
  e.scene({e.push("nodes", {{"mesh", e.quad(0)}})});
  std::string p = e.write("badsheen");
  EXPECT_EQ(error_of(p), p + ": /materials/0/extensions/KHR_materials_sheen/sheenColorFactor: expected colour values in [0, 1]");
}

TEST(GltfLoader, DiffuseTransmission) {
  // KHR_materials_diffuse_transmission: the weight (its texture's alpha moved to a grey copy's red) and the
  // colour (sRGB texture) in Material::diffuse_transmission and ::transmission; without the factor no textures;
  // defaults 0 and white; a weight outside [0, 1] and colours above 1 are errors.
  Builder b;
  b.j["extensionsUsed"] = {"KHR_materials_diffuse_transmission"};
  b.push("images", {{"uri", "data:image/png;base64," + base64(png(1, 1, {255, 128, 0, 102}, 4))}});
  b.push("textures", {{"source", 0}});
  b.push("materials", {{"extensions", {{"KHR_materials_diffuse_transmission",
                                        {{"diffuseTransmissionFactor", 0.75}, {"diffuseTransmissionColorFactor", {0.9, 0.5, 0.2}},
                                         {"diffuseTransmissionTexture", {{"index", 0}}},
                                         {"diffuseTransmissionColorTexture", {{"index", 0}}}}}}}});
  b.push("materials", {{"extensions", {{"KHR_materials_diffuse_transmission", {{"diffuseTransmissionTexture", {{"index", 0}}}}}}}});
  int q0 = b.quad(0), q1 = b.quad(1);
  b.scene({b.push("nodes", {{"mesh", q0}}), b.push("nodes", {{"mesh", q1}})});
  SceneDesc d = load_gltf_scene(b.write("difftrans"));
  ASSERT_EQ(d.materials.size(), 2u);
  const Material& m = d.materials[0];
  EXPECT_FLOAT_EQ(m.diffuse_transmission, 0.75f);
  expect_near(m.transmission, RGB(0.9f, 0.5f, 0.2f));
  ASSERT_GE(m.tex_diffuse_transmission, 0);
  ASSERT_GE(m.tex_diffuse_transmission_color, 0);
  EXPECT_FALSE(d.textures[size_t(m.tex_diffuse_transmission)].srgb);
  EXPECT_NEAR(d.textures[size_t(m.tex_diffuse_transmission)].rgba[0], 0.4f, 1e-6f);  // alpha 102/255
  EXPECT_TRUE(d.textures[size_t(m.tex_diffuse_transmission_color)].srgb);
  EXPECT_TRUE(material_is_transmissive(m));
  EXPECT_EQ(d.materials[1].diffuse_transmission, 0.f);
  expect_near(d.materials[1].transmission, RGB(1.f));
  EXPECT_EQ(d.materials[1].tex_diffuse_transmission, -1);
  EXPECT_FALSE(material_is_transmissive(d.materials[1]));
  const std::vector<std::tuple<std::string, json, std::string>> bad = {
      {"diffuseTransmissionFactor", 1.5, "expected a number in [0, 1]"},
      {"diffuseTransmissionColorFactor", json::array({1.5, 1.0, 1.0}), "expected colour values in [0, 1]"}};
  for (const auto& [key, value, what] : bad) {
    Builder e;
    e.push("materials", {{"extensions", {{"KHR_materials_diffuse_transmission", {{key, value}}}}}});
    e.scene({e.push("nodes", {{"mesh", e.quad(0)}})});
    std::string p = e.write("baddifftrans");
    EXPECT_EQ(error_of(p), p + ": /materials/0/extensions/KHR_materials_diffuse_transmission/" + key + ": " + what);
  }
}

TEST(GltfLoader, TransmissionTexture) {
  // KHR_materials_transmission's transmissionTexture (linear, its red channel scales transmissionFactor);
  // with factor 0 there is nothing to scale.
  Builder b;
  b.j["extensionsUsed"] = {"KHR_materials_transmission"};
  b.push("images", {{"uri", "data:image/png;base64," + base64(png(1, 1, {102, 0, 0}))}});
  b.push("textures", {{"source", 0}});
  b.push("materials", {{"extensions", {{"KHR_materials_transmission", {{"transmissionFactor", 0.9}, {"transmissionTexture", {{"index", 0}}}}}}}});
  b.push("materials", {{"extensions", {{"KHR_materials_transmission", {{"transmissionTexture", {{"index", 0}}}}}}}});
  int q0 = b.quad(0), q1 = b.quad(1);
  b.scene({b.push("nodes", {{"mesh", q0}}), b.push("nodes", {{"mesh", q1}})});
  SceneDesc d = load_gltf_scene(b.write("transmission_texture"));
  ASSERT_EQ(d.materials.size(), 2u);
  EXPECT_FLOAT_EQ(d.materials[0].transmission_weight, 0.9f);
  ASSERT_GE(d.materials[0].tex_transmission, 0);
  const TextureDesc& t = d.textures[size_t(d.materials[0].tex_transmission)];
  EXPECT_FALSE(t.srgb);
  EXPECT_NEAR(t.rgba[0], 0.4f, 1e-6f);
  EXPECT_EQ(d.materials[1].tex_transmission, -1);
  EXPECT_FALSE(has_warning(d, "transmissionTexture"));
}

TEST(GltfLoader, SamplerWrapsEachAxisItsOwnWay) {
  // wrapS along u and wrapT along v, each its own mode (no warning); each pair of modes its own copy of the
  // decoded image, also pairs that differ only along v.
  Builder b;
  std::vector<unsigned char> rgb = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255};
  b.push("images", {{"uri", "data:image/png;base64," + base64(png(2, 2, rgb))}});
  b.push("samplers", {{"wrapS", 10497}, {"wrapT", 33071}});
  b.push("samplers", {{"wrapS", 33648}, {"wrapT", 10497}});
  b.push("samplers", {{"wrapS", 10497}, {"wrapT", 33648}});
  for (int i = 0; i < 3; ++i) {
    b.push("textures", {{"source", 0}, {"sampler", i}});
    b.push("materials", {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", i}}}}}});
  }
  int q0 = b.quad(0), q1 = b.quad(1), q2 = b.quad(2);
  b.scene({b.push("nodes", {{"mesh", q0}}), b.push("nodes", {{"mesh", q1}}), b.push("nodes", {{"mesh", q2}})});
  SceneDesc d = load_gltf_scene(b.write("wraps"));
  const TextureDesc& a = d.textures[size_t(d.materials[0].tex_color)];
  const TextureDesc& m = d.textures[size_t(d.materials[1].tex_color)];
  EXPECT_EQ(a.wrap_u, TexWrap::kRepeat);
  EXPECT_EQ(a.wrap_v, TexWrap::kClamp);
  EXPECT_EQ(m.wrap_u, TexWrap::kMirror);
  EXPECT_EQ(m.wrap_v, TexWrap::kRepeat);
  const TextureDesc& r = d.textures[size_t(d.materials[2].tex_color)];
  EXPECT_NE(d.materials[2].tex_color, d.materials[0].tex_color);
  EXPECT_EQ(r.wrap_u, TexWrap::kRepeat);
  EXPECT_EQ(r.wrap_v, TexWrap::kMirror);
  EXPECT_FALSE(has_warning(d, "wrapT"));
}

TEST(GltfLoader, TexturesSamplersAndTransforms) {
  Builder b;
  std::vector<unsigned char> rgb = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255};  // 2x2: red green / blue white
  std::vector<unsigned char> img = png(2, 2, rgb);
  b.push("images", {{"uri", "data:image/png;base64," + base64(img)}});
  b.push("samplers", {{"magFilter", 9728}, {"wrapS", 33071}, {"wrapT", 33071}});
  b.push("textures", {{"source", 0}});
  b.push("textures", {{"source", 0}, {"sampler", 0}});
  // Two materials use the image as base colour (sRGB), one also as metallic-roughness (linear);
  // the second adds a texture transform.
  b.push("materials", {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}, {"metallicRoughnessTexture", {{"index", 0}}}}},
                       {"normalTexture", {{"index", 0}, {"scale", 0.5}}}});
  b.push("materials", {{"pbrMetallicRoughness",
                        {{"baseColorTexture",
                          {{"index", 1}, {"extensions", {{"KHR_texture_transform", {{"offset", {0.5, 0.25}}, {"scale", {2, 3}}}}}}}}}}});
  int q0 = b.quad(0), q1 = b.quad(1);
  int n0 = b.push("nodes", {{"mesh", q0}}), n1 = b.push("nodes", {{"mesh", q1}});
  b.scene({n0, n1});
  SceneDesc d = load_gltf_scene(b.write("textures"));
  // Textures: the image decoded as sRGB once and as linear once, plus the copy with the sampler + transform.
  ASSERT_EQ(d.textures.size(), 3u);
  const Material& m0 = d.materials[0];
  ASSERT_GE(m0.tex_color, 0);
  ASSERT_GE(m0.tex_roughness, 0);
  EXPECT_NE(m0.tex_color, m0.tex_roughness);
  EXPECT_EQ(m0.tex_normal, m0.tex_roughness);  // linear, same image: decoded once
  EXPECT_FLOAT_EQ(m0.normal_scale, 0.5f);
  const TextureDesc& c = d.textures[m0.tex_color];
  EXPECT_TRUE(c.srgb);
  EXPECT_EQ(c.width, 2);
  EXPECT_FLOAT_EQ(c.rgba[0], 1.f);   // red, top-left
  EXPECT_FLOAT_EQ(c.rgba[12 + 0], 1.f);  // white
  EXPECT_FALSE(c.nearest);
  const TextureDesc& t = d.textures[d.materials[1].tex_color];
  EXPECT_TRUE(t.nearest);
  EXPECT_EQ(t.wrap_u, TexWrap::kClamp);
  EXPECT_EQ(t.wrap_v, TexWrap::kClamp);
  EXPECT_EQ(t.rgba, c.rgba);
  // glTF uv' = (2u + 0.5, 3v + 0.25), v downwards. In caustica's v_c = 1 - v:
  // v_c' = 1 - (3 (1 - v_c) + 0.25) = 3 v_c - 2.25.
  EXPECT_FLOAT_EQ(t.uv_scale.x, 2.f);
  EXPECT_FLOAT_EQ(t.uv_scale.y, 3.f);
  EXPECT_FLOAT_EQ(t.uv_offset.x, 0.5f);
  EXPECT_FLOAT_EQ(t.uv_offset.y, -2.25f);
  EXPECT_FLOAT_EQ(t.uv_rotation, 0.f);
}

TEST(GltfLoader, MaterialVariantsReachTheMeshes) {
  // KHR_materials_variants: the chosen variant's material is the primitive's everywhere the loader reads it, the
  // mesh included: only a normal-mapped material gets the primitive tangents (generated here, there being no
  // TANGENT attribute). Materials of variants not chosen are not loaded.
  Builder b;
  std::vector<unsigned char> img = png(1, 1, {128, 128, 255});
  b.push("images", {{"uri", "data:image/png;base64," + base64(img)}});
  b.push("textures", {{"source", 0}});
  b.push("materials", {{"name", "plain"}});
  b.push("materials", {{"name", "bumpy"}, {"normalTexture", {{"index", 0}}}});
  b.push("materials", {{"name", "rough"}, {"pbrMetallicRoughness", {{"roughnessFactor", 0.25}}}});
  int q = b.quad(0);
  b.j["meshes"][q]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"] =
      json::array({{{"material", 1}, {"variants", {0}}}, {{"material", 2}, {"variants", {1}}}});
  b.j["extensions"]["KHR_materials_variants"]["variants"] = json::array({{{"name", "a"}}, {{"name", "b"}}});
  b.scene({b.push("nodes", {{"mesh", q}})});
  const std::string path = b.write("variants");
  struct Case {
    const char* variant;
    const char* material;
    bool tangents;
  };
  for (const Case& c : {Case{"", "plain", false}, Case{"a", "bumpy", true}, Case{"b", "rough", false}}) {
    SCOPED_TRACE(c.variant);
    SceneDesc d = load_gltf_scene(path, c.variant);
    EXPECT_EQ(d.variants, (std::vector<std::string>{"a", "b"}));
    EXPECT_EQ(d.variant, c.variant);
    ASSERT_EQ(d.shapes.size(), 1u);
    ASSERT_EQ(d.materials.size(), 1u);
    EXPECT_EQ(d.material_names[size_t(d.shapes[0].material)], c.material);
    EXPECT_EQ(d.meshes[size_t(d.shapes[0].mesh)].tangents.empty(), !c.tangents);
  }
  EXPECT_THROW(load_gltf_scene(path, "c"), InputError);
}

TEST(GltfLoader, TextureTransformRotationMatchesGltf) {
  // The stored transform in caustica's uv equals F o T_gltf o F with F(u, v) = (u, 1 - v).
  Builder b;
  b.push("images", {{"uri", "data:image/png;base64," + base64(png(1, 1, {10, 20, 30}))}});
  b.push("textures", {{"source", 0}});
  const double rot = 0.7, ox = 0.2, oy = -0.3, sx = 1.5, sy = 0.75;
  b.push("materials", {{"pbrMetallicRoughness",
                        {{"baseColorTexture",
                          {{"index", 0},
                           {"extensions", {{"KHR_texture_transform", {{"offset", {ox, oy}}, {"scale", {sx, sy}}, {"rotation", rot}}}}}}}}}});
  int q = b.quad(0);
  b.scene({b.push("nodes", {{"mesh", q}})});
  SceneDesc d = load_gltf_scene(b.write("rotation"));
  const TextureDesc& t = d.textures[d.materials[0].tex_color];
  auto caustica_map = [&](double u, double v) {
    double su = t.uv_scale.x * u, sv = t.uv_scale.y * v, c = std::cos(t.uv_rotation), s = std::sin(t.uv_rotation);
    return std::make_pair(c * su - s * sv + t.uv_offset.x, s * su + c * sv + t.uv_offset.y);
  };
  // KHR_texture_transform: T * R * S with GLSL mat3(cos, sin, 0, -sin, cos, 0, 0, 0, 1), whose
  // columns are (cos, sin) and (-sin, cos): u' = cos u - sin v, v' = sin u + cos v.
  auto gltf_map = [&](double u, double v) {
    double su = sx * u, sv = sy * v, c = std::cos(rot), s = std::sin(rot);
    return std::make_pair(c * su - s * sv + ox, s * su + c * sv + oy);
  };
  for (auto [u, v] : {std::make_pair(0.1, 0.2), std::make_pair(0.9, 0.4), std::make_pair(0.5, 0.95)}) {
    auto g = gltf_map(u, 1.0 - v);
    auto cm = caustica_map(u, v);
    EXPECT_NEAR(cm.first, g.first, 1e-5);
    EXPECT_NEAR(cm.second, 1.0 - g.second, 1e-5);
  }
}

TEST(GltfLoader, GlbWithEmbeddedImageAndDataUriBuffers) {
  for (int variant = 0; variant < 2; ++variant) {
    Builder b;
    std::vector<unsigned char> img = png(2, 1, {0, 0, 255, 255, 0, 0});
    int bv = b.view(img.data(), img.size());
    b.push("images", {{"bufferView", bv}, {"mimeType", "image/png"}});
    b.push("textures", {{"source", 0}});
    b.push("materials", {{"emissiveFactor", {1, 1, 1}}, {"emissiveTexture", {{"index", 0}}},
                         {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}});
    int q = b.quad(0);
    b.scene({b.push("nodes", {{"mesh", q}})});
    std::string path = variant == 0 ? b.write_glb("embedded") : b.write_data_uri("datauri");
    SceneDesc d = load_gltf_scene(path);
    ASSERT_EQ(d.shapes.size(), 1u);
    ASSERT_EQ(d.textures.size(), 1u);  // base colour and emission: one sRGB decode
    EXPECT_EQ(d.shapes[0].emission_texture, d.materials[0].tex_color);
    const TextureDesc& t = d.textures[0];
    EXPECT_EQ(t.width, 2);
    EXPECT_EQ(t.height, 1);
    EXPECT_FLOAT_EQ(t.rgba[2], 1.f);  // blue, left
    EXPECT_FLOAT_EQ(t.rgba[4], 1.f);  // red, right
    EXPECT_EQ(d.meshes[0].positions.size(), 4u);
  }
}

TEST(GltfLoader, ExternalImageFileAndStripsFansNonIndexed) {
  Builder b;
  std::vector<unsigned char> img = png(1, 1, {0, 128, 0});
  std::ofstream(temp_dir() / "tex image.png", std::ios::binary).write((const char*)img.data(), img.size());
  b.push("images", {{"uri", "tex%20image.png"}});
  b.push("textures", {{"source", 0}});
  b.push("materials", {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}});
  int pos = b.floats({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}, "VEC3", 4 - 1);
  int ind8 = b.indices(std::vector<uint8_t>{0, 1, 2, 3});
  int ind32 = b.indices(std::vector<uint32_t>{0, 1, 3, 2});
  json prims = json::array({
      {{"attributes", {{"POSITION", pos}}}, {"indices", ind8}, {"mode", 5}, {"material", 0}},  // strip: 2 triangles
      {{"attributes", {{"POSITION", pos}}}, {"indices", ind32}, {"mode", 6}},                  // fan: 2 triangles
      {{"attributes", {{"POSITION", pos}}}},                                                   // non-indexed: 1 triangle
      {{"attributes", {{"POSITION", pos}}}, {"mode", 1}}});                                    // lines: skipped
  int mesh = b.push("meshes", {{"primitives", prims}});
  b.scene({b.push("nodes", {{"mesh", mesh}})});
  SceneDesc d = load_gltf_scene(b.write("strips"));
  ASSERT_EQ(d.meshes.size(), 3u);
  EXPECT_EQ(d.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
  EXPECT_EQ(d.meshes[1].indices, (std::vector<uint32_t>{0, 1, 3, 0, 3, 2}));
  EXPECT_EQ(d.meshes[2].indices, (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_TRUE(d.meshes[0].normals.empty());
  EXPECT_TRUE(has_warning(d, "1 primitive(s) of points or lines skipped"));
  ASSERT_EQ(d.textures.size(), 1u);
  EXPECT_EQ(d.textures[0].name, (temp_dir() / "tex image.png").string());
  EXPECT_EQ(d.materials.size(), 2u);  // the material and the glTF default material
  EXPECT_EQ(d.material_names[1], "default");
}

TEST(GltfLoader, SparseAccessorAndNormalizedUVs) {
  Builder b;
  int pos = b.floats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3", 3);
  // Sparse: replace vertex 2 by (0, 2, 0).
  std::vector<uint8_t> si = {2};
  std::vector<float> sv = {0, 2, 0};
  int siv = b.view(si.data(), si.size()), svv = b.view(sv.data(), sv.size() * 4);
  b.j["accessors"][pos]["sparse"] = {{"count", 1}, {"indices", {{"bufferView", siv}, {"componentType", 5121}}},
                                     {"values", {{"bufferView", svv}}}};
  std::vector<uint16_t> uv = {0, 65535, 65535, 65535, 0, 0};
  int uvv = b.view(uv.data(), uv.size() * 2);
  int uva = b.push("accessors", {{"bufferView", uvv}, {"componentType", 5123}, {"normalized", true}, {"count", 3}, {"type", "VEC2"}});
  json prim = {{"attributes", {{"POSITION", pos}, {"TEXCOORD_0", uva}}}};
  int mesh = b.push("meshes", {{"primitives", json::array({prim})}});
  b.scene({b.push("nodes", {{"mesh", mesh}})});
  SceneDesc d = load_gltf_scene(b.write("sparse"));
  expect_near(d.meshes[0].positions[2], Vec3f(0, 2, 0));
  EXPECT_FLOAT_EQ(d.meshes[0].uvs[0].y, 0.f);  // glTF v = 1 -> caustica v = 0
  EXPECT_FLOAT_EQ(d.meshes[0].uvs[1].x, 1.f);
  EXPECT_FLOAT_EQ(d.meshes[0].uvs[2].y, 1.f);
}

namespace {
// A wavy 9 x 9 grid (128 triangles) with normals, UVs and colours, as triangle soup for Draco.
struct Grid {
  std::vector<Vec3f> p, n;
  std::vector<Vec2f> uv;  // glTF's (v = 0 at the top)
  std::vector<RGB> col;
};
Grid wavy_grid() {
  Grid g;
  auto vertex = [&](int i, int j) {
    const float x = i / 8.f * 2.f - 1.f, y = j / 8.f * 2.f - 1.f, z = 0.2f * std::sin(3.f * x) * std::cos(2.f * y);
    g.p.push_back(Vec3f(x, y, z));
    g.n.push_back(normalize(Vec3f(-0.6f * std::cos(3.f * x) * std::cos(2.f * y), 0.4f * std::sin(3.f * x) * std::sin(2.f * y), 1.f)));
    g.uv.push_back(Vec2f(i / 8.f, 1.f - j / 8.f));
    g.col.push_back(RGB(i / 8.f, j / 8.f, 0.5f));
  };
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j)
      for (auto [a, b] : {std::pair{0, 0}, {1, 0}, {1, 1}, {0, 0}, {1, 1}, {0, 1}}) vertex(i + a, j + b);
  return g;
}
}  // namespace

TEST(GltfLoader, DracoCompressedPrimitive) {
  // KHR_draco_mesh_compression: a grid encoded by Draco's own encoder (positions quantized to 14 bits, normals
  // 10, UVs 12, colours 8) loads as the same triangles: 128 of them, each loaded vertex within the
  // quantization step of a vertex of the original (2 / 2^14 in position; normals, UVs and colours 2^-6, loose
  // for their 8 to 12 bits), its normal, UV (flipped to caustica's v up) and colour those of that vertex, and
  // the total area that of the original (to 1e-3). The accessors have no bufferView: the glTF side gives only
  // type and count.
  const Grid g = wavy_grid();
  const int faces = int(g.p.size() / 3);
  draco::TriangleSoupMeshBuilder mb;
  mb.Start(faces);
  const int ap = mb.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
  const int an = mb.AddAttribute(draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32);
  const int at = mb.AddAttribute(draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32);
  const int ac = mb.AddAttribute(draco::GeometryAttribute::COLOR, 3, draco::DT_FLOAT32);
  for (int f = 0; f < faces; ++f) {
    const int v = 3 * f;
    mb.SetAttributeValuesForFace(ap, draco::FaceIndex(f), &g.p[v], &g.p[v + 1], &g.p[v + 2]);
    mb.SetAttributeValuesForFace(an, draco::FaceIndex(f), &g.n[v], &g.n[v + 1], &g.n[v + 2]);
    mb.SetAttributeValuesForFace(at, draco::FaceIndex(f), &g.uv[v], &g.uv[v + 1], &g.uv[v + 2]);
    mb.SetAttributeValuesForFace(ac, draco::FaceIndex(f), &g.col[v], &g.col[v + 1], &g.col[v + 2]);
  }
  std::unique_ptr<draco::Mesh> mesh = mb.Finalize();
  ASSERT_TRUE(mesh);
  draco::Encoder enc;
  enc.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 14);
  enc.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, 10);
  enc.SetAttributeQuantization(draco::GeometryAttribute::TEX_COORD, 12);
  enc.SetAttributeQuantization(draco::GeometryAttribute::COLOR, 8);
  draco::EncoderBuffer out;
  ASSERT_TRUE(enc.EncodeMeshToBuffer(*mesh, &out).ok());
  const size_t points = mesh->num_points();
  ASSERT_LT(points, g.p.size());  // shared corners were merged

  Builder b;
  const int bv = b.view(out.data(), out.size());
  auto acc = [&](const char* type, int ct, size_t count) {
    return b.push("accessors", {{"componentType", ct}, {"count", count}, {"type", type}});
  };
  json prim = {{"attributes", {{"POSITION", acc("VEC3", 5126, points)}, {"NORMAL", acc("VEC3", 5126, points)},
                               {"TEXCOORD_0", acc("VEC2", 5126, points)}, {"COLOR_0", acc("VEC3", 5126, points)}}},
               {"indices", acc("SCALAR", 5125, size_t(faces) * 3)}};
  prim["extensions"]["KHR_draco_mesh_compression"] = {
      {"bufferView", bv},
      {"attributes", {{"POSITION", mesh->attribute(ap)->unique_id()}, {"NORMAL", mesh->attribute(an)->unique_id()},
                      {"TEXCOORD_0", mesh->attribute(at)->unique_id()}, {"COLOR_0", mesh->attribute(ac)->unique_id()}}}};
  const int m = b.push("meshes", {{"primitives", json::array({prim})}});
  b.scene({b.push("nodes", {{"mesh", m}})});
  b.j["extensionsUsed"] = b.j["extensionsRequired"] = {"KHR_draco_mesh_compression"};
  const std::string path = b.write("draco");
  SceneDesc d = load_gltf_scene(path);
  ASSERT_EQ(d.meshes.size(), 1u);
  const MeshDesc& md = d.meshes[0];
  ASSERT_EQ(md.indices.size(), size_t(faces) * 3);
  ASSERT_EQ(md.positions.size(), points);
  ASSERT_EQ(md.normals.size(), points);
  ASSERT_EQ(md.uvs.size(), points);
  ASSERT_EQ(md.colors.size(), points);
  for (size_t i = 0; i < points; ++i) {
    size_t best = 0;
    for (size_t k = 1; k < g.p.size(); ++k)
      if (length(g.p[k] - md.positions[i]) < length(g.p[best] - md.positions[i])) best = k;
    expect_near(md.positions[i], g.p[best], 2.f / 16384.f);
    expect_near(md.normals[i], g.n[best], 1.f / 64.f);
    EXPECT_NEAR(md.uvs[i].x, g.uv[best].x, 1.f / 64.f);
    EXPECT_NEAR(md.uvs[i].y, 1.f - g.uv[best].y, 1.f / 64.f);
    expect_near(Vec3f(md.colors[i].x, md.colors[i].y, md.colors[i].z), Vec3f(g.col[best].x, g.col[best].y, g.col[best].z), 1.f / 64.f);
  }
  double area = 0.0, want = 0.0;
  for (size_t t = 0; t < md.indices.size(); t += 3) {
    const Vec3f a = md.positions[md.indices[t]], b1 = md.positions[md.indices[t + 1]], c = md.positions[md.indices[t + 2]];
    area += 0.5 * length(cross(b1 - a, c - a));
    want += 0.5 * length(cross(g.p[t + 1] - g.p[t], g.p[t + 2] - g.p[t]));
  }
  EXPECT_NEAR(area, want, 1e-3 * want);
  // The same as a GLB (its Draco data in the BIN chunk): the same mesh.
  Builder glb = b;
  const SceneDesc dg = load_gltf_scene(glb.write_glb("draco"));
  ASSERT_EQ(dg.meshes.size(), 1u);
  EXPECT_EQ(dg.meshes[0].indices, md.indices);
  ASSERT_EQ(dg.meshes[0].positions.size(), points);
  for (size_t i = 0; i < points; ++i) expect_near(dg.meshes[0].positions[i], md.positions[i], 0.f);

  // Corrupt Draco data and a wrong attribute id name their JSON paths.
  std::vector<unsigned char> junk(out.data(), out.data() + out.size());
  for (size_t i = 8; i < junk.size(); ++i) junk[i] = (unsigned char)(i * 37);
  Builder bad = b;
  bad.bin.assign(junk.begin(), junk.end());
  std::string e = error_of(bad.write("draco_junk"));
  EXPECT_NE(e.find("/meshes/0/primitives/0/extensions/KHR_draco_mesh_compression: cannot decode the Draco data"),
            std::string::npos) << e;
  Builder wrong = b;
  wrong.j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"]["NORMAL"] = 42;
  const std::string wp = wrong.write("draco_id");
  EXPECT_EQ(error_of(wp), wp + ": /meshes/0/primitives/0/extensions/KHR_draco_mesh_compression/attributes/NORMAL: the "
                               "Draco data has no attribute with id 42");
}

TEST(GltfLoader, MeshoptCompressedViews) {
  // EXT_meshopt_compression: a 9 x 9 grid (128 triangles) whose views meshoptimizer's encoders compressed into
  // buffer 0, with a fallback buffer 1 that has no data: positions (floats, no filter: lossless, so exact),
  // normals (8-bit octahedral, stride 4, byte normalized under KHR_mesh_quantization: within 2/127 of the unit
  // normal, twice the quantization step), UVs (the exponential filter with 16-bit mantissas: within 1e-4),
  // and indices (the triangle codec, which may rotate a triangle's corners but keeps its winding: the same
  // triangles up to rotation). The same mesh through INDICES mode (16-bit) gives the indices exactly.
  std::vector<float> pos, nor, uv;
  for (int j = 0; j <= 8; ++j)
    for (int i = 0; i <= 8; ++i) {
      const float x = i / 8.f * 2.f - 1.f, y = j / 8.f * 2.f - 1.f;
      pos.insert(pos.end(), {x, y, 0.2f * std::sin(3.f * x) * std::cos(2.f * y)});
      const Vec3f n = normalize(Vec3f(-0.6f * std::cos(3.f * x) * std::cos(2.f * y), 0.4f * std::sin(3.f * x) * std::sin(2.f * y), 1.f));
      nor.insert(nor.end(), {n.x, n.y, n.z, 0.f});
      uv.insert(uv.end(), {i / 8.f + 0.01f * j, 1.f - j / 8.f});
    }
  std::vector<uint32_t> idx;
  for (uint32_t j = 0; j < 8; ++j)
    for (uint32_t i = 0; i < 8; ++i) {
      const uint32_t a = j * 9 + i;
      idx.insert(idx.end(), {a, a + 1, a + 10, a, a + 10, a + 9});
    }
  const size_t nv = 81;
  std::vector<int8_t> oct(nv * 4);
  meshopt_encodeFilterOct(oct.data(), nv, 4, 8, nor.data());
  std::vector<uint32_t> expuv(nv * 2);
  meshopt_encodeFilterExp(expuv.data(), nv, 8, 16, uv.data());

  for (const char* index_mode : {"TRIANGLES", "INDICES"}) {
    Builder b;
    size_t fallback = 0;  // bytes of the fallback buffer
    auto compressed = [&](const void* data, size_t count, size_t stride, const char* mode, const char* filter, bool vertex) {
      std::vector<unsigned char> enc;
      if (std::string(mode) == "ATTRIBUTES") {
        enc.resize(meshopt_encodeVertexBufferBound(count, stride));
        enc.resize(meshopt_encodeVertexBuffer(enc.data(), enc.size(), data, count, stride));
      } else {
        std::vector<uint32_t> ix(static_cast<const uint32_t*>(data), static_cast<const uint32_t*>(data) + count);
        enc.resize(meshopt_encodeIndexBufferBound(count, nv));
        enc.resize(std::string(mode) == "TRIANGLES" ? meshopt_encodeIndexBuffer(enc.data(), enc.size(), ix.data(), count)
                                                     : meshopt_encodeIndexSequence(enc.data(), enc.size(), ix.data(), count));
      }
      while (b.bin.size() % 4) b.bin.push_back(0);
      const size_t off = b.bin.size();
      b.bin.insert(b.bin.end(), enc.begin(), enc.end());
      json v = {{"buffer", 1}, {"byteOffset", fallback}, {"byteLength", count * stride}};
      if (vertex) v["byteStride"] = stride;
      v["extensions"]["EXT_meshopt_compression"] = {{"buffer", 0}, {"byteOffset", off}, {"byteLength", enc.size()},
                                                    {"byteStride", stride}, {"count", count}, {"mode", mode}, {"filter", filter}};
      fallback += count * stride;
      return b.push("bufferViews", v);
    };
    const int vp = compressed(pos.data(), nv, 12, "ATTRIBUTES", "NONE", true);
    const int vn = compressed(oct.data(), nv, 4, "ATTRIBUTES", "OCTAHEDRAL", true);
    const int vt = compressed(expuv.data(), nv, 8, "ATTRIBUTES", "EXPONENTIAL", true);
    const bool tri = std::string(index_mode) == "TRIANGLES";
    const int vi = compressed(idx.data(), idx.size(), tri ? 4 : 2, index_mode, "NONE", false);
    json attrs = {{"POSITION", b.push("accessors", {{"bufferView", vp}, {"componentType", 5126}, {"count", nv}, {"type", "VEC3"}})},
                  {"NORMAL", b.push("accessors", {{"bufferView", vn}, {"componentType", 5120}, {"normalized", true},
                                                  {"count", nv}, {"type", "VEC3"}})},
                  {"TEXCOORD_0", b.push("accessors", {{"bufferView", vt}, {"componentType", 5126}, {"count", nv}, {"type", "VEC2"}})}};
    const int ia = b.push("accessors", {{"bufferView", vi}, {"componentType", tri ? 5125 : 5123}, {"count", idx.size()},
                                        {"type", "SCALAR"}});
    const int m = b.push("meshes", {{"primitives", json::array({{{"attributes", attrs}, {"indices", ia}}})}});
    b.scene({b.push("nodes", {{"mesh", m}})});
    json fb = {{"byteLength", fallback}};
    fb["extensions"]["EXT_meshopt_compression"]["fallback"] = true;
    b.j["buffers"] = json::array({json::object(), fb});
    b.j["extensionsUsed"] = {"EXT_meshopt_compression", "KHR_mesh_quantization"};
    b.j["extensionsRequired"] = {"EXT_meshopt_compression", "KHR_mesh_quantization"};
    for (int glb = 0; glb < 2; ++glb) {
      Builder w = b;
      const std::string path = glb ? w.write_glb("meshopt") : w.write("meshopt");
      SceneDesc d = load_gltf_scene(path);
      ASSERT_EQ(d.meshes.size(), 1u) << index_mode;
      const MeshDesc& md = d.meshes[0];
      ASSERT_EQ(md.positions.size(), nv);
      ASSERT_EQ(md.normals.size(), nv);
      ASSERT_EQ(md.uvs.size(), nv);
      for (size_t v = 0; v < nv; ++v) {
        expect_near(md.positions[v], Vec3f(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]), 0.f);
        expect_near(md.normals[v], Vec3f(nor[4 * v], nor[4 * v + 1], nor[4 * v + 2]), 2.f / 127.f);
        EXPECT_NEAR(md.uvs[v].x, uv[2 * v], 1e-4f);
        EXPECT_NEAR(md.uvs[v].y, 1.f - uv[2 * v + 1], 1e-4f);
      }
      ASSERT_EQ(md.indices.size(), idx.size());
      auto canonical = [](const std::vector<uint32_t>& ix, size_t t) {
        std::array<uint32_t, 3> c{ix[t], ix[t + 1], ix[t + 2]};
        while (c[0] > c[1] || c[0] > c[2]) std::rotate(c.begin(), c.begin() + 1, c.end());
        return c;
      };
      for (size_t t = 0; t < idx.size(); t += 3) EXPECT_EQ(canonical(md.indices, t), canonical(idx, t)) << t;
      if (!tri) EXPECT_EQ(md.indices, idx);
    }
  }
}

TEST(GltfLoader, MeshoptErrors) {
  // A view into a fallback buffer without EXT_meshopt_compression, a bad mode, and data that does not decode.
  Builder b;
  b.bin.assign(64, 0x55);
  b.push("bufferViews", {{"buffer", 1}, {"byteLength", 12}});
  b.scene({});
  json fb = {{"byteLength", 12}};
  fb["extensions"]["EXT_meshopt_compression"]["fallback"] = true;
  b.j["buffers"] = json::array({json::object(), fb});
  std::string p = b.write("meshopt_plain");
  EXPECT_EQ(error_of(p), p + ": /bufferViews/0: refers to buffer 1, an EXT_meshopt_compression fallback without data, "
                             "but has no EXT_meshopt_compression of its own");
  b.j["bufferViews"][0]["extensions"]["EXT_meshopt_compression"] = {{"buffer", 0}, {"byteLength", 64}, {"byteStride", 4},
                                                                   {"count", 3}, {"mode", "VERTICES"}};
  p = b.write("meshopt_mode");
  EXPECT_EQ(error_of(p), p + ": /bufferViews/0/extensions/EXT_meshopt_compression/mode: expected ATTRIBUTES, TRIANGLES or "
                             "INDICES, got 'VERTICES'");
  b.j["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["mode"] = "ATTRIBUTES";
  b.j["bufferViews"][0]["byteStride"] = 4;
  {  // An image in a compressed view (which tinygltf would read from the fallback buffer, which has no data).
    Builder im = b;
    im.push("images", {{"bufferView", 0}, {"mimeType", "image/png"}});
    p = im.write("meshopt_image");
    EXPECT_EQ(error_of(p), p + ": /images/0/bufferView: refers to bufferView 0, which EXT_meshopt_compression "
                               "compresses (images are stored as they are)");
  }
  const int a = b.push("accessors", {{"bufferView", 0}, {"componentType", 5126}, {"count", 1}, {"type", "VEC3"}});
  b.j["meshes"] = json::array({{{"primitives", json::array({{{"attributes", {{"POSITION", a}}}}})}}});
  b.scene({b.push("nodes", {{"mesh", 0}})});
  p = b.write("meshopt_junk");
  const std::string e = error_of(p);
  EXPECT_EQ(e, p + ": /bufferViews/0/extensions/EXT_meshopt_compression: cannot decode the compressed ATTRIBUTES "
                   "(meshoptimizer error -1)") << e;  // -1: the first byte is not a known version
}

TEST(GltfLoader, BadGeometryIsSkippedWithCountedWarnings) {
  Builder b;
  float nan = std::nanf("");
  int pos = b.floats({0, 0, 0, 1, 0, 0, 0, 1, 0, nan, 0, 0, 2, 0, 0}, "VEC3", 3);
  // Triangles: good; uses the NaN vertex; degenerate (collinear); out-of-range index 9; good.
  int ind = b.indices(std::vector<uint16_t>{0, 1, 2, 0, 3, 1, 0, 1, 4, 0, 9, 1, 2, 1, 0});
  b.push("materials", {{"emissiveFactor", {1, 1, 1}}});
  json prim = {{"attributes", {{"POSITION", pos}}}, {"indices", ind}, {"material", 0}};
  int mesh = b.push("meshes", {{"primitives", json::array({prim})}});
  int n0 = b.push("nodes", {{"mesh", mesh}});
  int n1 = b.push("nodes", {{"mesh", mesh}, {"scale", {0, 0, 0}}});  // a zero-area light instance
  b.scene({n0, n1});
  SceneDesc d = load_gltf_scene(b.write("badgeom"));
  ASSERT_EQ(d.meshes.size(), 1u);
  EXPECT_EQ(d.meshes[0].indices.size(), 6u);
  for (Vec3f p : d.meshes[0].positions) EXPECT_TRUE(std::isfinite(p.x));
  ASSERT_EQ(d.shapes.size(), 1u);
  std::string f = (temp_dir() / "badgeom.gltf").string();
  EXPECT_TRUE(has_warning(d, f + ": 1 triangle(s) with non-finite (NaN or infinite) vertex positions skipped"));
  EXPECT_TRUE(has_warning(d, f + ": 1 degenerate (zero-area) triangle(s) skipped"));
  EXPECT_TRUE(has_warning(d, f + ": 1 triangle(s) with vertex indices out of range skipped"));
  EXPECT_TRUE(has_warning(d, f + ": 1 mesh instance(s) with a singular (zero-scale) transform skipped"));
}

TEST(GltfLoader, MalformedInputMessages) {
  std::string dir = temp_dir().string();
  // Bad JSON names the line.
  std::string p = write_text("badjson.gltf", "{\n  \"asset\": {\"version\": \"2.0\"},\n  \"nodes\": [,]\n}\n");
  EXPECT_EQ(error_of(p), p + ":3: invalid JSON: syntax error while parsing value - unexpected ','; expected '[', '{', or a literal");
  // A number too large for a double (found by the fuzzer: it escaped as a JSON library exception).
  p = write_text("overflow.gltf", "{\n  \"asset\": {\"version\": \"2.0\"},\n  \"x\": 0.9e795\n}\n");
  EXPECT_EQ(error_of(p), p + ":3: invalid JSON: number overflow parsing '0.9e795'");
  p = write_text("noasset.gltf", "{}");
  EXPECT_EQ(error_of(p), p + ": /asset: missing (every glTF file has an asset object with a version)");
  p = write_text("v1.gltf", R"({"asset": {"version": "1.0"}})");
  EXPECT_EQ(error_of(p), p + ": /asset/version: glTF version '1.0' is not supported (expected 2.x)");
  p = write_text("req.gltf", R"({"asset": {"version": "2.0"}, "extensionsRequired": ["KHR_texture_basisu"]})");
  EXPECT_EQ(error_of(p), p + ": /extensionsRequired/0: extension 'KHR_texture_basisu' is required but not supported "
                             "(supported: EXT_mesh_gpu_instancing, EXT_meshopt_compression, EXT_texture_webp, KHR_draco_mesh_compression, KHR_lights_punctual, KHR_materials_anisotropy, "
                             "KHR_materials_clearcoat, KHR_materials_diffuse_transmission, KHR_materials_emissive_strength, KHR_materials_ior, KHR_materials_iridescence, "
                             "KHR_materials_pbrSpecularGlossiness, KHR_materials_sheen, KHR_materials_specular, KHR_materials_transmission, KHR_materials_unlit, KHR_materials_variants, KHR_materials_volume, "
                       "KHR_mesh_quantization, KHR_node_visibility, "
                             "KHR_texture_transform)");
  // A missing buffer file names both files.
  p = write_text("nobuf.gltf", R"({"asset": {"version": "2.0"}, "buffers": [{"uri": "missing.bin", "byteLength": 4}]})");
  EXPECT_EQ(error_of(p), p + ": /buffers/0/uri: buffer file '" + dir + "/missing.bin' does not exist");
  {  // A missing image file names both files.
    Builder b;
    b.push("images", {{"uri", "nothere.png"}});
    b.push("textures", {{"source", 0}});
    b.push("materials", {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}});
    int q = b.quad(0);
    b.scene({b.push("nodes", {{"mesh", q}})});
    p = b.write("noimage");
    EXPECT_EQ(error_of(p), p + ": /images/0/uri: image file '" + dir + "/nothere.png' does not exist");
  }
  {  // Out-of-range accessor index.
    Builder b;
    int q = b.quad();
    b.j["meshes"][q]["primitives"][0]["attributes"]["NORMAL"] = 42;
    b.scene({b.push("nodes", {{"mesh", q}})});
    p = b.write("badaccessor");
    EXPECT_EQ(error_of(p), p + ": /meshes/0/primitives/0/attributes/NORMAL: index 42 out of range (/accessors has 4 entries)");
  }
  {  // A node referencing a missing mesh.
    Builder b;
    b.scene({b.push("nodes", {{"mesh", 0}})});
    p = b.write("nomesh");
    EXPECT_EQ(error_of(p), p + ": /nodes/0/mesh: index 0 out of range (/meshes is empty)");
  }
  {  // An accessor reading past its buffer view.
    Builder b;
    int q = b.quad();
    b.j["accessors"][0]["count"] = 5;
    b.scene({b.push("nodes", {{"mesh", q}})});
    p = b.write("pastview");
    EXPECT_EQ(error_of(p), p + ": /accessors/0: needs bytes [0, 60) of bufferView 0, which has 48 bytes");
  }
  {  // Indices of the wrong type.
    Builder b;
    int q = b.quad();
    b.j["meshes"][q]["primitives"][0]["indices"] = 0;  // the float positions
    b.scene({b.push("nodes", {{"mesh", q}})});
    p = b.write("floatindices");
    EXPECT_EQ(error_of(p), p + ": /meshes/0/primitives/0/indices: expected an accessor of unsigned byte, short or int "
                               "scalars (5121, 5123, 5125), got accessor 0 of VEC3 5126");
  }
  {  // A node with two parents.
    Builder b;
    int c = b.push("nodes", json::object());
    int a = b.push("nodes", {{"children", {c}}});
    b.push("nodes", {{"children", {c}}});
    b.scene({a});
    p = b.write("twoparents");
    EXPECT_EQ(error_of(p), p + ": /nodes/2/children/0: node 0 already has a parent (node 1; nodes must form trees)");
  }
  {  // Missing POSITION, a bad camera, a bad light.
    Builder b;
    int q = b.quad();
    b.j["meshes"][q]["primitives"][0]["attributes"].erase("POSITION");
    b.scene({b.push("nodes", {{"mesh", q}})});
    p = b.write("nopos");
    EXPECT_EQ(error_of(p), p + ": /meshes/0/primitives/0/attributes: missing POSITION");
  }
  p = write_text("badcam.gltf", R"({"asset": {"version": "2.0"}, "cameras": [{"type": "perspective", "perspective": {"znear": 0.1}}]})");
  EXPECT_EQ(error_of(p), p + ": /cameras/0/perspective/yfov: missing (the vertical field of view in radians)");
  p = write_text("badfar.gltf", R"({"asset": {"version": "2.0"}, "cameras": [{"type": "perspective", "perspective": {"yfov": 1, "znear": 0.1, "zfar": 0.1}}]})");
  EXPECT_EQ(error_of(p), p + ": /cameras/0/perspective/zfar: expected a distance beyond znear");
  p = write_text("badnear.gltf", R"({"asset": {"version": "2.0"}, "cameras": [{"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": -1, "zfar": 2}}]})");
  EXPECT_EQ(error_of(p), p + ": /cameras/0/orthographic/znear: expected a distance >= 0");
  p = write_text("badlight.gltf", R"({"asset": {"version": "2.0"}, "extensions": {"KHR_lights_punctual": {"lights": [{"type": "area"}]}}})");
  EXPECT_EQ(error_of(p), p + ": /extensions/KHR_lights_punctual/lights/0/type: unknown light type 'area' (expected point, spot or directional)");
  {  // Negative emissive factor.
    Builder b;
    b.push("materials", {{"emissiveFactor", {1, -1, 1}}});
    int q = b.quad(0);
    b.scene({b.push("nodes", {{"mesh", q}})});
    p = b.write("negemission");
    EXPECT_EQ(error_of(p), p + ": /materials/0/emissiveFactor: expected non-negative colour values");
  }
  // GLB container errors.
  p = write_text("short.glb", "glTF");
  EXPECT_EQ(error_of(p), p + ": invalid GLB file: shorter than the 12-byte header and a chunk header");
  p = write_text("notglb.glb", "{\"asset\": {}}");
  EXPECT_EQ(error_of(p), p + ": not a GLB file (expected the magic bytes 'glTF' at the start)");
  {
    Builder b;
    int q = b.quad();
    b.scene({b.push("nodes", {{"mesh", q}})});
    p = b.write_glb("truncated");
    size_t size = fs::file_size(p);
    fs::resize_file(p, size - 8);
    EXPECT_EQ(error_of(p), p + ": invalid GLB file: the header's length " + std::to_string(size) +
                               " exceeds the file size " + std::to_string(size - 8));
  }
}
