// The CPU's ray queries over the scene's flat arrays. By default (Kind::kAuto) a scene of at most
// SmallAccel::kMaxTriangles triangles and kMaxSmallSpheres spheres is queried by SmallAccel (every triangle
// tested, eight at a time: on such scenes Embree's fixed cost per query is most of its time; measured in
// bench/RESULTS.md, 2026-12-02), any other scene by Embree 3: all triangles in one triangle geometry
// (primID = triangle index) and all spheres in one user geometry that calls the same intersect_sphere()
// as the GPU path. Kind::kEmbree always uses Embree. Cut-outs (materials with kAlphaTested, scene/opacity.h)
// are tested in Embree's filter functions, with the same code as the portable BVH; SmallAccel does not
// take scenes with them.
#pragma once
#include <embree3/rtcore.h>

#include <memory>

#include "../../scene/scene_view.h"
#include "small_accel.h"

namespace caustica {

class CpuAccel {
 public:
  enum class Kind { kAuto, kEmbree, kSmall };
  // The most spheres a scene may have for Kind::kAuto to choose SmallAccel (its spheres are tested one by
  // one after the triangles).
  static constexpr uint32_t kMaxSmallSpheres = 8;
  // Whether Kind::kAuto chooses SmallAccel for this scene on this CPU.
  static bool small_suits(const SceneView& view);

  // kSmall requires small_suits(view).
  explicit CpuAccel(const SceneView& view, Kind kind = Kind::kAuto);
  ~CpuAccel();
  CpuAccel(const CpuAccel&) = delete;
  CpuAccel& operator=(const CpuAccel&) = delete;

  // kEmbree or kSmall: what answers the queries.
  Kind kind() const { return small_ ? Kind::kSmall : Kind::kEmbree; }
  // "embree" or "small".
  const char* name() const { return small_ ? "small" : "embree"; }

  // Closest hit in (0, ray.tmax); false and an invalid hit when nothing is hit.
  bool intersect(const Ray& ray, Hit& hit) const;
  // Any hit in (0, ray.tmax).
  bool occluded(const Ray& ray) const;
  // The rays of the lanes whose bit is set in `mask`: hits[i] for each (SmallAccel::intersect8; Embree
  // one ray at a time), and the bits of the occluded ones.
  void intersect8(const RayLanes& rays, int mask, Hit hits[8]) const;
  int occluded8(const RayLanes& rays, int mask) const;

 private:
  std::unique_ptr<SmallAccel> small_;
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  unsigned tri_geom_ = RTC_INVALID_GEOMETRY_ID, sphere_geom_ = RTC_INVALID_GEOMETRY_ID;
  uint32_t num_triangles_ = 0;
  SceneView view_;  // the scene's arrays, for the spheres' and cut-outs' callbacks
};

// Traversal of the portable BVH (the GPU's), with the same interface.
struct BVHAccel {
  const SceneView* view;
  bool intersect(const Ray& ray, Hit& hit) const;
  bool occluded(const Ray& ray) const;
  void intersect8(const RayLanes& rays, int mask, Hit hits[8]) const;
  int occluded8(const RayLanes& rays, int mask) const;
};

}  // namespace caustica
