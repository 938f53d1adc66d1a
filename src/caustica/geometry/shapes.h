// Ray-primitive intersection and uniform area sampling for triangles and
// spheres. Triangles: Moller & Trumbore 1997, "Fast, Minimum Storage
// Ray/Triangle Intersection". Spheres: the numerically careful quadratic of
// Haines et al. 2019, "Precision Improvements for Ray/Sphere Intersection"
// (Ray Tracing Gems, chapter 7, Eqs. 7.5-7.9).
#pragma once
#include "../base/math.h"
#include "ray.h"

namespace caustica {

struct Sphere {
  Vec3f center;
  float radius;
};

// Returns true and fills t, b1, b2 when the ray hits triangle (p0, p1, p2) in (tmin, tmax).
CHD bool intersect_triangle(const Ray& r, Vec3f p0, Vec3f p1, Vec3f p2, float& t, float& b1, float& b2) {
  Vec3f e1 = p1 - p0, e2 = p2 - p0;
  Vec3f pv = cross(r.d, e2);
  float det = dot(e1, pv);
  if (det == 0.f || !std::isfinite(det)) return false;
  float inv = 1.f / det;
  Vec3f tv = r.o - p0;
  float u = dot(tv, pv) * inv;
  if (u < 0.f || u > 1.f) return false;
  Vec3f qv = cross(tv, e1);
  float v = dot(r.d, qv) * inv;
  if (v < 0.f || u + v > 1.f) return false;
  float tt = dot(e2, qv) * inv;
  if (!(tt > 0.f) || !(tt < r.tmax)) return false;
  t = tt; b1 = u; b2 = v;
  return true;
}

// Nearest intersection of the ray with the sphere beyond t = 0 and below tmax.
CHD bool intersect_sphere(const Ray& r, const Sphere& s, float& t_out) {
  Vec3f f = r.o - s.center;
  float a = dot(r.d, r.d);
  float b = -dot(f, r.d);  // b' of Eq. 7.5 with the sign folded in
  Vec3f l = f + (b / a) * r.d;
  float disc = a * (s.radius * s.radius - dot(l, l));  // Eq. 7.9
  if (disc < 0.f) return false;
  float sq = std::sqrt(disc);
  float q = b + std::copysign(sq, b);  // Eq. 7.8: no cancellation
  float c = dot(f, f) - s.radius * s.radius;
  float t0 = c / q, t1 = q / a;
  if (t0 > t1) { float tmp = t0; t0 = t1; t1 = tmp; }
  float t = t0 > 0.f ? t0 : t1;
  if (!(t > 0.f) || !(t < r.tmax)) return false;
  // Reject hits that lie on the surface the ray starts from (|o - c| ~ r).
  if (t == t0 && t < 1e-6f * s.radius) { if (t1 > 0.f && t1 < r.tmax) t = t1; else return false; }
  t_out = t;
  return true;
}

CHD Bounds3 sphere_bounds(const Sphere& s) {
  Bounds3 b;
  b.lo = s.center - Vec3f(s.radius);
  b.hi = s.center + Vec3f(s.radius);
  return b;
}

CHD float triangle_area(Vec3f p0, Vec3f p1, Vec3f p2) {
  return 0.5f * length(cross(p1 - p0, p2 - p0));
}

}  // namespace caustica
