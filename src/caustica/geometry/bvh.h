// The project's own bounding volume hierarchy: a binned-SAH build on the host
// (Wald 2007, "On fast Construction of SAH-based Bounding Volume Hierarchies")
// and a stack-based traversal that runs on the CPU and the GPU alike. On the
// CPU, Embree is the default accelerator; this BVH is the portable reference
// and the one the CUDA backend traverses.
#pragma once
#include <cstdint>
#include "../base/math.h"
#include "ray.h"

namespace caustica {

struct BVHNode {
  Bounds3 bounds;
  // Interior: count == 0, left child is this index + 1, right child is `offset`.
  // Leaf: primitives prim_index[offset .. offset + count).
  uint32_t offset = 0;
  uint32_t count = 0;
};

struct BVHView {
  const BVHNode* nodes = nullptr;
  const uint32_t* prim_index = nullptr;
  uint32_t num_nodes = 0;
};

CHD bool ray_box(const Bounds3& b, Vec3f o, Vec3f inv_d, float tmax, float& tnear) {
  float t0 = 0.f, t1 = tmax;
  for (int a = 0; a < 3; ++a) {
    float tn = (b.lo[a] - o[a]) * inv_d[a];
    float tf = (b.hi[a] - o[a]) * inv_d[a];
    if (tn > tf) { float tmp = tn; tn = tf; tf = tmp; }
    tf *= 1.f + 2.f * 1.1920929e-07f * 2.f;  // conservative (pbrt-v4 Eq. 6.10 gamma)
    t0 = tn > t0 ? tn : t0;
    t1 = tf < t1 ? tf : t1;
    if (t0 > t1) return false;
  }
  tnear = t0;
  return true;
}

// Traverses the BVH; `test(prim, ray)` intersects one primitive, shortening
// ray.tmax on a hit, and returns whether it hit. With any_hit the first hit ends it.
template <typename PrimTest>
CHD bool bvh_traverse(const BVHView& bvh, Ray& ray, bool any_hit, PrimTest&& test) {
  if (bvh.num_nodes == 0) return false;
  Vec3f inv_d(1.f / ray.d.x, 1.f / ray.d.y, 1.f / ray.d.z);
  uint32_t stack[64];
  int sp = 0;
  uint32_t node = 0;
  bool hit = false;
  while (true) {
    const BVHNode& n = bvh.nodes[node];
    float tn;
    if (ray_box(n.bounds, ray.o, inv_d, ray.tmax, tn)) {
      if (n.count > 0) {
        for (uint32_t i = 0; i < n.count; ++i) {
          if (test(bvh.prim_index[n.offset + i], ray)) {
            hit = true;
            if (any_hit) return true;
          }
        }
      } else {
        // Visit the child on the ray's near side first.
        uint32_t left = node + 1, right = n.offset;
        float tl, tr;
        bool hl = ray_box(bvh.nodes[left].bounds, ray.o, inv_d, ray.tmax, tl);
        bool hr = ray_box(bvh.nodes[right].bounds, ray.o, inv_d, ray.tmax, tr);
        if (hl && hr) {
          if (tr < tl) { uint32_t tmp = left; left = right; right = tmp; }
          stack[sp++] = right;
          node = left;
          continue;
        }
        if (hl) { node = left; continue; }
        if (hr) { node = right; continue; }
      }
    }
    if (sp == 0) break;
    node = stack[--sp];
  }
  return hit;
}

}  // namespace caustica
