// Surface data at a ray hit, computed from the flat scene arrays.
#pragma once
#include "scene_view.h"

namespace caustica {

struct SurfaceHit {
  Vec3f p;
  Vec3f ng;  // geometric normal (triangle winding / sphere outward)
  Vec3f ns;  // shading normal, on the same side as ng
  uint32_t prim;
  uint32_t material;
  int32_t light;
};

CHD void triangle_vertices(const SceneView& s, uint32_t tri, Vec3f& p0, Vec3f& p1, Vec3f& p2) {
  p0 = s.positions[s.indices[3 * tri + 0]];
  p1 = s.positions[s.indices[3 * tri + 1]];
  p2 = s.positions[s.indices[3 * tri + 2]];
}

CHD SurfaceHit make_surface_hit(const SceneView& s, const Ray& r, const Hit& h) {
  SurfaceHit sh;
  sh.prim = h.prim;
  sh.material = s.prim_material[h.prim];
  sh.light = s.prim_light[h.prim];
  if (h.prim < s.num_triangles) {
    Vec3f p0, p1, p2;
    triangle_vertices(s, h.prim, p0, p1, p2);
    float b0 = 1.f - h.b1 - h.b2;
    sh.p = p0 * b0 + p1 * h.b1 + p2 * h.b2;  // barycentric: more accurate than o + t d
    sh.ng = normalize(cross(p1 - p0, p2 - p0));
    sh.ns = sh.ng;
    if (s.normals) {
      const uint32_t* ix = s.indices + 3 * h.prim;
      Vec3f n = s.normals[ix[0]] * b0 + s.normals[ix[1]] * h.b1 + s.normals[ix[2]] * h.b2;
      if (length_sq(n) > 0.f) sh.ns = face_forward(normalize(n), sh.ng);
    }
  } else {
    const Sphere& sp = s.spheres[h.prim - s.num_triangles];
    Vec3f p = r.o + r.d * h.t;
    sh.ng = normalize(p - sp.center);
    sh.p = sp.center + sh.ng * sp.radius;  // re-project onto the surface
    sh.ns = sh.ng;
  }
  return sh;
}

}  // namespace caustica
