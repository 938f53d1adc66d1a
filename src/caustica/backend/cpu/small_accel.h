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

 private:
  // Eight triangles' vertices: p[vertex][axis][lane], their primitive indices (-1: an unused lane) and a
  // bit per used lane.
  struct alignas(32) Block {
    float p[3][3][8];
    int32_t prim[8];
    int valid = 0;
  };
  std::vector<Block> blocks_;
  uint32_t num_triangles_ = 0;
  std::vector<Sphere> spheres_;
};

}  // namespace caustica
