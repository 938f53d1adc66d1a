#include "load.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "../base/error.h"
#include "builtin/builtin.h"
#include "loaders/gltf_loader.h"
#include "loaders/json_loader.h"
#include "loaders/mesh_loaders.h"
#include "loaders/mitsuba_loader.h"

namespace caustica {

namespace {

bool emits_light(const SceneDesc& d) {
  if (!d.lights.empty()) return true;
  for (const ShapeDesc& s : d.shapes)
    if (max_component(s.emission) > 0.f) return true;
  return false;
}

SceneDesc load_mesh_file(const std::string& path, const std::string& ext) {
  SceneDesc d;
  d.name = std::filesystem::path(path).stem().string();
  if (ext == ".ply") {
    d.meshes.push_back(load_ply_mesh(path, &d.warnings));
    // Grey diffuse; a mesh with vertex colours shows them (reflectance 1 times the colour, as an OBJ file's
    // default material and glTF's do).
    Material m = make_diffuse(RGB(d.meshes[0].colors.empty() ? 0.5f : 1.f));
    if (!d.meshes[0].colors.empty()) m.flags |= kVertexColor;
    d.add_material(d.meshes[0].colors.empty() ? "default" : "default+colors", m);
    ShapeDesc s;
    s.name = d.name;
    s.mesh = 0;
    d.shapes.push_back(s);
  } else {
    append_obj(d, path, Affine(), -1, path);
  }
  add_default_camera_and_light(d, true);
  return d;
}

}  // namespace

void add_default_camera_and_light(SceneDesc& d, bool need_camera) {
  SceneStats st = scene_stats(d);
  if (need_camera) {
    Vec3f c = (st.lo + st.hi) * 0.5f;
    float r = 0.5f * length(st.hi - st.lo);
    if (!(r > 0.f)) r = 1.f;
    CameraDesc cam;
    cam.fov_degrees = 40.f;
    cam.width = cam.height = 512;
    cam.target = c;
    cam.position = c + Vec3f(0.f, 0.f, 1.1f * r / std::sin(0.5f * cam.fov_degrees * kPi / 180.f));
    d.camera = cam;
    d.warnings.push_back(d.name + ": no camera in the file; using a default camera looking down -z at the scene");
  }
  if (!emits_light(d)) {
    Light env;
    env.type = LightType::kEnvironment;
    env.L = RGB(1.f);
    d.lights.push_back(env);
    d.warnings.push_back(d.name + ": no lights in the file; using a constant white environment (radiance 1)");
  }
}

SceneStats scene_stats(const SceneDesc& d) {
  SceneStats st;
  st.shapes = d.shapes.size();
  st.meshes = d.meshes.size();
  st.materials = d.materials.size();
  st.textures = d.textures.size();
  st.lights = d.lights.size();
  Vec3f lo(kInf), hi(-kInf);
  auto grow = [&](Vec3f p) {
    lo = vmin(lo, p);
    hi = vmax(hi, p);
  };
  for (const ShapeDesc& s : d.shapes) {
    bool emissive = max_component(s.emission) > 0.f;
    if (emissive) ++st.area_lights;
    switch (s.type) {
      case ShapeType::kSphere: {
        ++st.spheres;
        float r = s.radius * length(s.to_world.vector(Vec3f(1, 0, 0)));
        Vec3f c = s.to_world.point(s.center);
        grow(c - Vec3f(r));
        grow(c + Vec3f(r));
        break;
      }
      case ShapeType::kRectangle:
      case ShapeType::kDisk:
        st.triangles += s.type == ShapeType::kRectangle ? 2 : 128;
        for (float x : {-1.f, 1.f})
          for (float y : {-1.f, 1.f}) grow(s.to_world.point(Vec3f(x, y, 0.f)));
        break;
      case ShapeType::kCube:
        st.triangles += 12;
        for (float x : {-1.f, 1.f})
          for (float y : {-1.f, 1.f})
            for (float z : {-1.f, 1.f}) grow(s.to_world.point(Vec3f(x, y, z)));
        break;
      case ShapeType::kMesh:
        if (s.mesh >= 0 && size_t(s.mesh) < d.meshes.size()) {
          const MeshDesc& m = d.meshes[s.mesh];
          st.triangles += m.indices.size() / 3;
          for (Vec3f p : m.positions) grow(s.to_world.point(p));
        }
        break;
    }
  }
  if (lo.x <= hi.x) {
    st.lo = lo;
    st.hi = hi;
  }
  return st;
}

SceneDesc load_scene_desc(const std::string& name_or_path, const LoadOptions& opts) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path p(name_or_path);
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  const bool gltf = ext == ".gltf" || ext == ".glb";
  if (!opts.variant.empty() && !gltf)
    throw InputError(name_or_path + ": has no material variants (--variant '" + opts.variant +
                     "'): they come from glTF files (KHR_materials_variants)");
  if (is_builtin_scene(name_or_path) && !fs::exists(name_or_path, ec)) return builtin_scene(name_or_path);
  if (fs::exists(p, ec)) {
    if (fs::is_directory(p, ec)) throw InputError(name_or_path + ": is a directory, not a scene file");
    SceneDesc d;
    if (ext == ".json") d = load_json_scene_file(name_or_path);
    else if (ext == ".obj" || ext == ".ply") d = load_mesh_file(name_or_path, ext);
    else if (gltf) d = load_gltf_scene(name_or_path, opts.variant);
    else if (ext == ".xml") d = load_mitsuba_scene(name_or_path, opts.params);
    else
      throw InputError(name_or_path + ": unsupported scene format '" + ext +
                       "' (supported: .json, .obj, .ply, .gltf, .glb, .xml)");
    if (!opts.camera.empty()) select_camera(d, opts.camera);
    return d;
  }
  if (!ext.empty() || name_or_path.find('/') != std::string::npos)
    throw InputError(name_or_path + ": no such file");
  return builtin_scene(name_or_path);  // throws with the list of names
}

void select_camera(SceneDesc& d, const std::string& name) {
  std::string names;
  for (const CameraDesc& c : d.cameras) {
    if (c.name == name) {
      d.camera = c;
      return;
    }
    names += (names.empty() ? "" : ", ") + c.name;
  }
  throw InputError(d.name + ": no camera named '" + name + "' (cameras: " + (names.empty() ? "none" : names) + ")");
}

}  // namespace caustica
