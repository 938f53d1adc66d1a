// Closest-hit and any-hit queries over the portable BVH: what the GPU runs,
// and the CPU's reference against Embree.
#pragma once
#include "opacity.h"

namespace caustica {

struct PrimIntersector {
  const SceneView* s;
  Hit* hit;
  CHD bool operator()(uint32_t prim, Ray& ray) const {
    float t, b1 = 0.f, b2 = 0.f;
    bool ok;
    if (prim < s->num_triangles) {
      const uint32_t* ix = s->indices + 3 * prim;
      ok = intersect_triangle(ray, s->positions[ix[0]], s->positions[ix[1]], s->positions[ix[2]], t, b1, b2);
      // A cut-out skips the candidate (scene/opacity.h); traversal goes on beyond it.
      if (ok && s->alpha_tested) ok = triangle_hit_kept(*s, prim, b1, b2, ray);
    } else {
      ok = intersect_sphere_kept(*s, prim - s->num_triangles, ray, t);
    }
    if (!ok) return false;
    ray.tmax = t;
    if (hit) { hit->t = t; hit->prim = prim; hit->b1 = b1; hit->b2 = b2; }
    return true;
  }
};

CHD bool scene_intersect(const SceneView& s, Ray ray, Hit& hit) {
  hit = Hit();
  return bvh_traverse(s.bvh, ray, false, PrimIntersector{&s, &hit});
}
CHD bool scene_occluded(const SceneView& s, Ray ray) {
  return bvh_traverse(s.bvh, ray, true, PrimIntersector{&s, nullptr});
}

}  // namespace caustica
