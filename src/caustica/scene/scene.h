// Scene: the flat arrays built from a SceneDesc, the portable BVH, and a view
// (SceneView) over them for the integrators.
#pragma once
#include <memory>
#include <string>
#include <vector>
#include "../geometry/bvh_build.h"
#include "scene_desc.h"
#include "scene_view.h"

namespace caustica {

class CpuAccel;

class Scene {
 public:
  static std::shared_ptr<Scene> build(const SceneDesc& desc);
  ~Scene();

  const SceneView& view() const { return view_; }
  const SceneDesc& desc() const { return desc_; }
  // The CPU's ray queries (CpuAccel::Kind::kAuto: the small-scene test or Embree, by the scene's size).
  const CpuAccel& accel() const { return *accel_; }
  // Embree's ray queries whatever the scene's size (the same object as accel() when that is Embree).
  const CpuAccel& embree() const { return embree_ ? *embree_ : *accel_; }
  // The one an `accel` option names: "embree" embree(); "small" accel() where that is the small-scene test
  // (else an InputError saying why not); "auto" (and "bvh", which the CPU's photon tracers do not take)
  // accel().
  const CpuAccel& cpu_accel(const std::string& accel) const;
  // Changes resolution (and the derived camera) without rebuilding geometry.
  void set_resolution(int width, int height);  // the film's size (a crop window stays, and must fit)
  // Renders the pixels [x, x + width) x [y, y + height) of the film (all zero: the whole film).
  void set_crop(int x, int y, int width, int height);
  void set_filter(const Filter& f) { view_.filter = f; }

  std::vector<Vec3f> positions, normals;
  std::vector<Vec2f> uvs;  // empty, or one per position
  std::vector<RGB> colors;  // empty, or one per position (white where a mesh has none)
  std::vector<Tangent> tangents;  // empty, or one per position (w = 0 where a mesh has none)
  std::vector<TextureView> textures;  // views into desc().textures
  std::vector<float> env_func, env_cond_cdf, env_marg_cdf, env_marg_func;
  std::vector<uint32_t> indices;
  std::vector<Sphere> spheres;
  std::vector<Frame> sphere_frames;  // empty, or one per sphere (where any sphere is rotated)
  std::vector<uint32_t> prim_material;
  std::vector<int32_t> prim_light;
  std::vector<Material> materials;
  std::vector<Medium> media;
  std::vector<MediumInterface> prim_medium;  // empty, or one per primitive (where some shape has an interface)
  std::vector<MediumGrid> medium_grids;  // one per SceneDesc::grids entry
  std::vector<float> grid_values;        // their samples, one after another (MediumGrid::offset)
  std::vector<Light> lights;
  std::vector<float> alias_prob, light_pmf;
  std::vector<uint32_t> alias_index;
  std::vector<LightBvhNode> light_bvh_nodes;
  std::vector<uint64_t> light_bvh_trail;
  std::vector<uint32_t> light_bvh_where, light_bvh_infinite;
  std::vector<uint16_t> sheen_table;  // SceneView::sheen_table (empty: none)
  BVH bvh;

 private:
  Scene() = default;
  void update_view();
  void build_envmap(const TextureView& tex, const Affine& to_world);
  SceneDesc desc_;
  SceneView view_;
  std::unique_ptr<CpuAccel> accel_;
  std::unique_ptr<CpuAccel> embree_;  // only where accel_ is not Embree
};

Camera make_camera(const CameraDesc& c);
// The flat density grids of desc.grids (medium/medium_grid.h); InputError for a grid that is not valid.
void build_medium_grids(const SceneDesc& desc, std::vector<MediumGrid>& grids, std::vector<float>& values);
// Power of a light (luminance of its emitted flux), for the light sampler.
float light_power(const SceneView& s, const Light& l);

}  // namespace caustica
