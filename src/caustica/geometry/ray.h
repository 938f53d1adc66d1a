// Rays, bounds and the hit record returned by every accelerator.
#pragma once
#include <cstdint>
#include "../base/math.h"

namespace caustica {

struct Ray {
  Vec3f o, d;
  float tmax = kInf;
};

// What an accelerator returns: the distance, the primitive (triangles first,
// then spheres) and the triangle barycentrics (b1, b2) of vertices 1 and 2.
struct Hit {
  float t = kInf;
  uint32_t prim = ~0u;
  float b1 = 0.f, b2 = 0.f;
  CHD bool valid() const { return prim != ~0u; }
};

struct Bounds3 {
  Vec3f lo{kInf, kInf, kInf}, hi{-kInf, -kInf, -kInf};
  CHD void extend(Vec3f p) { lo = vmin(lo, p); hi = vmax(hi, p); }
  CHD void extend(const Bounds3& b) { lo = vmin(lo, b.lo); hi = vmax(hi, b.hi); }
  CHD Vec3f centroid() const { return (lo + hi) * 0.5f; }
  CHD Vec3f diagonal() const { return hi - lo; }
  CHD float surface_area() const {
    Vec3f d = diagonal();
    return (d.x < 0.f) ? 0.f : 2.f * (d.x * d.y + d.y * d.z + d.z * d.x);
  }
  CHD bool empty() const { return hi.x < lo.x; }
};

// Offsets a surface point along the geometric normal so that a ray leaving it
// on the side of w does not hit the surface again. The offset scales with the
// magnitude of the coordinates, like the float error bounds of pbrt-v4 3.9.
CHD Vec3f offset_ray_origin(Vec3f p, Vec3f ng, Vec3f w) {
  float scale = 1e-4f * maxf(1.f, max_component(vabs(p)));
  Vec3f off = ng * scale;
  return dot(w, ng) < 0.f ? p - off : p + off;
}

// A shadow ray from a point already offset off its surface (`o`) to a point on
// a light, offset along its own normal towards `o` (pbrt-v4's SpawnRayTo): the
// unnormalised direction spans the segment, which ends just short of the
// target (tmax = 1 - 1e-4). A zero n_to means a point light (no offset).
CHD Ray spawn_ray_to(Vec3f o, Vec3f p_to, Vec3f n_to) {
  Ray r;
  r.o = o;
  Vec3f target = (n_to.x == 0.f && n_to.y == 0.f && n_to.z == 0.f) ? p_to : offset_ray_origin(p_to, n_to, o - p_to);
  r.d = target - o;
  r.tmax = 1.f - 1e-4f;
  return r;
}

}  // namespace caustica
