// Embree 3 ray queries over the scene's flat arrays: all triangles in one
// triangle geometry (primID = triangle index) and all spheres in one user
// geometry that calls the same intersect_sphere() as the GPU path.
#pragma once
#include <embree3/rtcore.h>

#include "../../scene/scene_view.h"

namespace caustica {

class EmbreeAccel {
 public:
  explicit EmbreeAccel(const SceneView& view);
  ~EmbreeAccel();
  EmbreeAccel(const EmbreeAccel&) = delete;
  EmbreeAccel& operator=(const EmbreeAccel&) = delete;

  // Closest hit in (0, ray.tmax); false and an invalid hit when nothing is hit.
  bool intersect(const Ray& ray, Hit& hit) const;
  // Any hit in (0, ray.tmax).
  bool occluded(const Ray& ray) const;

 private:
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  unsigned tri_geom_ = RTC_INVALID_GEOMETRY_ID, sphere_geom_ = RTC_INVALID_GEOMETRY_ID;
  uint32_t num_triangles_ = 0;
  const Sphere* spheres_ = nullptr;
};

// Traversal of the portable BVH (the GPU's), with the same interface.
struct BVHAccel {
  const SceneView* view;
  bool intersect(const Ray& ray, Hit& hit) const;
  bool occluded(const Ray& ray) const;
};

}  // namespace caustica
