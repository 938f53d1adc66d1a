// Ray-primitive intersection and uniform area sampling for triangles and
// spheres. Triangles: Woop, Benthin, Wald 2013, "Watertight Ray/Triangle
// Intersection" (the portable BVH's test; Embree's is watertight too). Spheres: the numerically careful quadratic of
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

// A mesh vertex's tangent (glTF 2.0 TANGENT, pbrt-v4's per-vertex s): t points along +u of the texture
// parameterisation, and the bitangent (along +v, v up) is w * cross(normal, t) with the vertex normal.
// w is +1 or -1 (mirrored UVs); w = 0 marks a vertex without one, where the triangle's own dp/du is used.
struct Tangent {
  Vec3f t;
  float w = 0.f;
};

// Returns true and fills t, b1, b2 (the weights of p1 and p2) when the ray hits
// triangle (p0, p1, p2) at 0 < t < tmax. Watertight (Woop, Benthin, Wald 2013,
// "Watertight Ray/Triangle Intersection", JCGT 2(1)): the vertices are moved into a
// frame where the ray starts at the origin and runs along +z (a permutation of the
// axes, largest direction component last, then a shear), so that the three edge
// functions U, V, W are evaluated on the same projected vertices for both
// triangles sharing an edge; an edge function that comes out exactly 0 is
// recomputed in double precision, so rays through shared edges and vertices hit at
// least one of the triangles (tests/cpp/test_triangle.cpp).
CHD bool intersect_triangle(const Ray& r, Vec3f p0, Vec3f p1, Vec3f p2, float& t, float& b1, float& b2) {
  float adx = std::fabs(r.d.x), ady = std::fabs(r.d.y), adz = std::fabs(r.d.z);
  int kz = adx > ady ? (adx > adz ? 0 : 2) : (ady > adz ? 1 : 2);
  int kx = kz == 2 ? 0 : kz + 1, ky = kx == 2 ? 0 : kx + 1;
  if (r.d[kz] < 0.f) { int tmp = kx; kx = ky; ky = tmp; }  // keeps the winding (the sign of det)
  if (r.d[kz] == 0.f) return false;                          // a zero or NaN direction
  float sz = 1.f / r.d[kz], sx = r.d[kx] * sz, sy = r.d[ky] * sz;
  Vec3f a = p0 - r.o, b = p1 - r.o, c = p2 - r.o;
  float ax = a[kx] - sx * a[kz], ay = a[ky] - sy * a[kz];
  float bx = b[kx] - sx * b[kz], by = b[ky] - sy * b[kz];
  float cx = c[kx] - sx * c[kz], cy = c[ky] - sy * c[kz];
  float u = cx * by - cy * bx;  // edge p1-p2: the weight of p0
  float v = ax * cy - ay * cx;  // edge p2-p0: the weight of p1
  float w = bx * ay - by * ax;  // edge p0-p1: the weight of p2
  if (u == 0.f || v == 0.f || w == 0.f) {
    u = float(double(cx) * double(by) - double(cy) * double(bx));
    v = float(double(ax) * double(cy) - double(ay) * double(cx));
    w = float(double(bx) * double(ay) - double(by) * double(ax));
  }
  if ((u < 0.f || v < 0.f || w < 0.f) && (u > 0.f || v > 0.f || w > 0.f)) return false;
  float det = u + v + w;
  if (det == 0.f || !std::isfinite(det)) return false;
  float az = sz * a[kz], bz = sz * b[kz], cz = sz * c[kz];
  float tt = u * az + v * bz + w * cz;  // t * det
  if (det < 0.f ? (tt >= 0.f || !(tt > r.tmax * det)) : (tt <= 0.f || !(tt < r.tmax * det))) return false;
  float inv = 1.f / det;
  float th = tt * inv;
  if (!(th > 0.f) || !(th < r.tmax)) return false;
  t = th;
  b1 = v * inv;
  b2 = w * inv;
  return true;
}

// Both roots t0 <= t1 of |o + t d - c| = r (false when the ray's line misses the sphere).
CHD bool sphere_roots(const Ray& r, const Sphere& s, float& t0, float& t1) {
  Vec3f f = r.o - s.center;
  float a = dot(r.d, r.d);
  float b = -dot(f, r.d);  // b' of Eq. 7.5 with the sign folded in
  Vec3f l = f + (b / a) * r.d;
  float disc = a * (s.radius * s.radius - dot(l, l));  // Eq. 7.9
  if (disc < 0.f) return false;
  float sq = std::sqrt(disc);
  float q = b + std::copysign(sq, b);  // Eq. 7.8: no cancellation
  float c = dot(f, f) - s.radius * s.radius;
  t0 = c / q;
  t1 = q / a;
  if (t0 > t1) { float tmp = t0; t0 = t1; t1 = tmp; }
  return true;
}

// Whether root t0 (the near crossing) counts as a hit: beyond t = 0 and below tmax, and not on the surface the
// ray starts from (|o - c| ~ r).
CHD bool sphere_near_root_ok(const Ray& r, const Sphere& s, float t0) {
  return t0 > 0.f && t0 < r.tmax && !(t0 < 1e-6f * s.radius);
}

// Nearest intersection of the ray with the sphere beyond t = 0 and below tmax.
CHD bool intersect_sphere(const Ray& r, const Sphere& s, float& t_out) {
  float t0, t1;
  if (!sphere_roots(r, s, t0, t1)) return false;
  if (sphere_near_root_ok(r, s, t0)) {
    t_out = t0;
    return true;
  }
  if (t0 > 0.f && !(t0 < 1e-6f * s.radius)) return false;  // the near crossing is beyond tmax
  if (!(t1 > 0.f) || !(t1 < r.tmax)) return false;
  t_out = t1;
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
