// SceneDesc: the plain-data description every loader produces (built-in
// scenes, JSON, and later OBJ/glTF/Mitsuba XML). It holds no pointers into
// libraries; Scene::build turns it into flat arrays and acceleration structures.
#pragma once
#include <string>
#include <vector>
#include "../camera/camera.h"
#include "../film/filter.h"
#include "../light/light.h"
#include "../material/material.h"

namespace caustica {

struct MeshDesc {
  std::string name;
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;  // empty, or one per position
  std::vector<uint32_t> indices;  // 3 per triangle
};

enum class ShapeType { kMesh, kSphere, kRectangle, kCube, kDisk };

struct ShapeDesc {
  std::string name;
  ShapeType type = ShapeType::kMesh;
  int mesh = -1;             // kMesh: index into SceneDesc::meshes (shared meshes are instances)
  Affine to_world;           // local to world (applied to every type)
  Vec3f center{0.f};         // kSphere (before to_world)
  float radius = 1.f;        // kSphere
  int material = 0;
  RGB emission{0.f};         // radiance; non-zero makes the shape an area light
  bool emission_two_sided = false;
  bool flip_normals = false;
};

struct CameraDesc {
  Vec3f position{0, 0, 0}, target{0, 0, -1}, up{0, 1, 0};
  float fov_degrees = 39.3077f;
  enum class FovAxis { kSmaller, kX, kY } fov_axis = FovAxis::kSmaller;
  float aperture_radius = 0.f;
  float focus_distance = 0.f;  // 0: distance to target
  int width = 256, height = 256;
};

struct SceneDesc {
  std::string name;
  CameraDesc camera;
  FilterType filter = FilterType::kBox;
  std::vector<std::string> material_names;
  std::vector<Material> materials;
  std::vector<MeshDesc> meshes;
  std::vector<ShapeDesc> shapes;
  std::vector<Light> lights;  // point, spot, directional, environment (area lights come from shapes)
  int max_depth = -1;  // the scene's preferred default (-1: unlimited)

  int add_material(const std::string& name, const Material& m) {
    material_names.push_back(name);
    materials.push_back(m);
    return int(materials.size()) - 1;
  }
};

// Material constructors with the parameters people know.
Material make_diffuse(RGB reflectance, bool two_sided = false);
Material make_mirror(RGB tint = RGB(1.f));
Material make_conductor(RGB eta, RGB k, RGB tint = RGB(1.f), float alpha = 0.f);
Material make_dielectric(float eta, float alpha = 0.f);
Material make_thin_dielectric(float eta);
Material make_plastic(RGB diffuse, float eta = 1.49f, RGB specular = RGB(1.f));
Material make_diffuse_transmission(RGB reflectance, RGB transmittance);
Material make_phong(RGB kd, RGB ks, float exponent);
// Hemispherical average of dielectric Fresnel reflectance, 2 int_0^1 F(mu) mu dmu.
float diffuse_fresnel_reflectance(float eta);

}  // namespace caustica
