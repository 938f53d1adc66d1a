// Scene: the flat arrays built from a SceneDesc, the portable BVH, and a view
// (SceneView) over them for the integrators.
#pragma once
#include <memory>
#include <vector>
#include "../geometry/bvh_build.h"
#include "scene_desc.h"
#include "scene_view.h"

namespace caustica {

class EmbreeAccel;

class Scene {
 public:
  static std::shared_ptr<Scene> build(const SceneDesc& desc);
  ~Scene();

  const SceneView& view() const { return view_; }
  const SceneDesc& desc() const { return desc_; }
  const EmbreeAccel& embree() const { return *embree_; }
  // Changes resolution (and the derived camera) without rebuilding geometry.
  void set_resolution(int width, int height);
  void set_filter(FilterType f) { view_.filter = f; }

  std::vector<Vec3f> positions, normals;
  std::vector<Vec2f> uvs;  // empty, or one per position
  std::vector<TextureView> textures;  // views into desc().textures
  std::vector<float> env_func, env_cond_cdf, env_marg_cdf, env_marg_func;
  std::vector<uint32_t> indices;
  std::vector<Sphere> spheres;
  std::vector<uint32_t> prim_material;
  std::vector<int32_t> prim_light;
  std::vector<Material> materials;
  std::vector<Light> lights;
  std::vector<float> alias_prob, light_pmf;
  std::vector<uint32_t> alias_index;
  BVH bvh;

 private:
  Scene() = default;
  void update_view();
  void build_envmap(const TextureView& tex, const Affine& to_world);
  SceneDesc desc_;
  SceneView view_;
  std::unique_ptr<EmbreeAccel> embree_;
};

Camera make_camera(const CameraDesc& c);
// Power of a light (luminance of its emitted flux), for the light sampler.
float light_power(const SceneView& s, const Light& l);

}  // namespace caustica
