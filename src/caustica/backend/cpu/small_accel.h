// Ray queries for scenes of a few dozen primitives, without a hierarchy: one ray against eight triangles
// at a time (AVX2), then the spheres one by one. On such scenes a query through Embree costs mostly its
// fixed overhead (dispatch, robust node tests, leaf set-up); testing every triangle in eight-wide blocks
// costs less (bench/RESULTS.md, 2026-12-02). The triangle test is intersect_triangle's (geometry/shapes.h:
// the watertight test of Woop, Benthin and Wald 2013), lane for lane the same IEEE operations, so each
// triangle's answer is bit for bit the scalar one; of several hits the closest is kept, and of hits at
// equal distance the lowest primitive index.
#pragma once
#include <cstdint>
#include <vector>

#include "../../scene/scene_view.h"

namespace caustica {

// Eight rays, a lane each (the lane-parallel driver's layout, integrator/path_lanes.cpp).
struct alignas(32) RayLanes {
  float ox[8], oy[8], oz[8], dx[8], dy[8], dz[8], tmax[8];
  Ray ray(int i) const {
    Ray r;
    r.o = Vec3f(ox[i], oy[i], oz[i]);
    r.d = Vec3f(dx[i], dy[i], dz[i]);
    r.tmax = tmax[i];
    return r;
  }
};

class SmallAccel {
 public:
  // Whether this build and this CPU run it (x86-64 with AVX2, GCC or Clang).
  static bool available();
  // The most triangles it takes (sixteen blocks of eight): up to here it answers faster than Embree
  // (bench/RESULTS.md, 2026-12-02 06:30; primary rays break even between 128 and 192 triangles).
  static constexpr uint32_t kMaxTriangles = 128;
  explicit SmallAccel(const SceneView& view);

  // Closest hit in (0, ray.tmax); false and an invalid hit when nothing is hit.
  bool intersect(const Ray& ray, Hit& hit) const;
  // Any hit in (0, ray.tmax).
  bool occluded(const Ray& ray) const;
  // The same for the rays of the lanes whose bit is set in `mask`, with the rays' set-up (the axis
  // permutation and shear) done for all eight at once: hits[i] for each such lane i (the others are left
  // as they are); occluded8 returns the bits of the occluded rays. Each answer is intersect's or
  // occluded's for that ray.
  void intersect8(const RayLanes& rays, int mask, Hit hits[8]) const;
  int occluded8(const RayLanes& rays, int mask) const;

  // Eight triangles' vertices: p[vertex][axis][lane], their primitive indices (-1: an unused lane) and a
  // bit per used lane.
  struct alignas(32) Block {
    float p[3][3][8];
    int32_t prim[8];
    int valid = 0;
  };

 private:
  void closest_sphere(Ray r, Hit& hit) const;
  bool any_sphere(const Ray& ray) const;
  std::vector<Block> blocks_;
  uint32_t num_triangles_ = 0;
  std::vector<Sphere> spheres_;
};

}  // namespace caustica
