// Surface data at a ray hit, computed from the flat scene arrays.
#pragma once
#include "../base/rng.h"
#include "scene_view.h"

namespace caustica {

struct SurfaceHit {
  Vec3f p;
  Vec3f ng;  // geometric normal (triangle winding / sphere outward)
  Vec3f ns;  // shading normal, on the same side as ng
  Vec2f uv;  // texture coordinates (v up); barycentrics (b1, b2) on meshes without UVs
  uint32_t prim;
  uint32_t material;  // a leaf material: blends and pairs of sides resolved (resolve_material)
  int32_t light;
};

// Texture coordinates at barycentrics (b1, b2) of a triangle.
CHD Vec2f triangle_uv(const SceneView& s, uint32_t tri, float b1, float b2) {
  if (!s.uvs) return Vec2f(b1, b2);
  const uint32_t* ix = s.indices + 3 * tri;
  return s.uvs[ix[0]] * (1.f - b1 - b2) + s.uvs[ix[1]] * b1 + s.uvs[ix[2]] * b2;
}
// The interpolated vertex colour of triangle `tri` at its point p (SceneView::colors, which must be set): the
// barycentrics of p's projection onto the triangle's plane (p lies in it up to rounding), clamped to the triangle.
CHD RGB triangle_color(const SceneView& s, uint32_t tri, Vec3f p) {
  const uint32_t* ix = s.indices + 3 * tri;
  const Vec3f v0 = s.positions[ix[0]], e1 = s.positions[ix[1]] - v0, e2 = s.positions[ix[2]] - v0, d = p - v0;
  const float a = dot(e1, e1), b = dot(e1, e2), c = dot(e2, e2), det = a * c - b * b;
  float b1 = 0.f, b2 = 0.f;
  if (det > 0.f) {
    const float d1 = dot(d, e1), d2 = dot(d, e2);
    b1 = clampf((c * d1 - b * d2) / det, 0.f, 1.f);
    b2 = clampf((a * d2 - b * d1) / det, 0.f, 1.f - b1);
  }
  return s.colors[ix[0]] * (1.f - b1 - b2) + s.colors[ix[1]] * b1 + s.colors[ix[2]] * b2;
}
// Sphere parameterisation: u = phi / 2pi around +z, v = 1 - theta / pi with theta
// from +z, so the image's top row is at the +z pole (Mitsuba's layout, whose
// v = theta / pi is counted downwards in the image).
CHD Vec2f sphere_uv(Vec3f n) {
  float phi = std::atan2(n.y, n.x);
  if (phi < 0.f) phi += 2.f * kPi;
  return Vec2f(phi * (0.5f * kInvPi), 1.f - std::acos(clampf(n.z, -1.f, 1.f)) * kInvPi);
}

// Direction n from sphere i's centre in the sphere's own frame (SceneView::sphere_frames; the world's when
// it has none), and the texture coordinates there: a rotated sphere's texture turns with it, as in Mitsuba 3
// and pbrt-v4, whose spheres measure (phi, theta) in object space.
CHD Vec3f sphere_local(const SceneView& s, uint32_t i, Vec3f n) {
  return s.sphere_frames ? s.sphere_frames[i].to_local(n) : n;
}
CHD Vec2f sphere_uv_at(const SceneView& s, uint32_t i, Vec3f n) { return sphere_uv(sphere_local(s, i, n)); }

CHD void triangle_vertices(const SceneView& s, uint32_t tri, Vec3f& p0, Vec3f& p1, Vec3f& p2) {
  p0 = s.positions[s.indices[3 * tri + 0]];
  p1 = s.positions[s.indices[3 * tri + 1]];
  p2 = s.positions[s.indices[3 * tri + 2]];
}

// A uniform number in [0, 1) from a surface point, its primitive and a salt: a blend's choice there
// (resolve_material).
CHD float point_hash(Vec3f p, uint32_t prim, uint32_t salt) {
  uint64_t a = (uint64_t(float_bits(p.x)) << 32) | float_bits(p.y);
  uint64_t b = (uint64_t(float_bits(p.z)) << 32) | prim;
  return u32_to_unit_float(uint32_t(hash3(a, b, 0x5bd1e995ULL + salt) >> 32));
}

// The material that a ray travelling along d meets at sh, with the blends above it resolved
// (Material::mix_a, mix_b):
// - a pair of sides (kSides; Mitsuba 3's twosided of two BSDFs) is mix_a where the ray arrives on the front
//   (the side ng faces) and mix_b where it arrives from behind (Scene::build makes mix_b's materials
//   two-sided, so the back is evaluated as if seen from its own front);
// - a blend is one of its two materials at each point, mix_b with probability w: the choice is a hash of the
//   point (point_hash), so a point shows the same material to every ray, light subpath and photon, and over
//   any area the shares are the weights, as a texture of fine grain would have them. pbrt-v4's MixMaterial
//   chooses the same way from a hash of the point and the direction; Mitsuba 3's blendbsdf evaluates both
//   and samples one, which has the same expected value.
// Resolved once per hit (make_surface_hit), so SurfaceHit::material is always a leaf material.
CHD uint32_t resolve_material(const SceneView& s, uint32_t mi, const SurfaceHit& sh, Vec3f d) {
  for (uint32_t depth = 0; depth < kMaxMixDepth; ++depth) {
    const Material& m = s.materials[mi];
    if (m.mix_b < 0) break;
    if (m.flags & kSides) {
      mi = uint32_t(dot(d, sh.ng) > 0.f ? m.mix_b : m.mix_a);
      continue;
    }
    float w = m.mix_weight;
    if (m.tex_mix >= 0) {
      RGBA c = texture_lookup(s.textures[m.tex_mix], sh.uv);
      w *= 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b;
    }
    mi = uint32_t(point_hash(sh.p, sh.prim, depth) < w ? m.mix_b : m.mix_a);
  }
  return mi;
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
    sh.uv = triangle_uv(s, h.prim, h.b1, h.b2);
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
    sh.uv = sphere_uv_at(s, h.prim - s.num_triangles, sh.ng);
  }
  sh.material = resolve_material(s, sh.material, sh, r.d);
  return sh;
}

}  // namespace caustica
