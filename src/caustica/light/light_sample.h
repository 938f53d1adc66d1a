// Next-event estimation: sampling a point or direction on a light as seen from
// a reference point, and the matching solid-angle density for MIS.
#pragma once
#include "../scene/opacity.h"
#include "light.h"

namespace caustica {

struct LightSample {
  RGB Li{0.f};      // radiance (or intensity / d^2, irradiance) arriving at ref
  Vec3f wi;         // unit direction from ref towards the light
  float dist = kInf;  // distance to the light point (infinite for distant lights)
  float pdf = 0.f;  // solid-angle density (1 for delta lights)
  bool delta = false;
  Vec3f p_l, n_l;   // area lights: the sampled point and its geometric normal (else n_l = 0)
  Vec2f uv_l;       // area lights: the sampled point's texture coordinates
};

// Radiance of an area light at surface texture coordinates uv (emission texture applied). A point sampled on
// the light is further weighted by area_coverage (scene/opacity.h) where the light has cut-outs; a ray that
// hits the light has passed them already.
CHD RGB area_radiance(const SceneView& s, const Light& l, Vec3f n, Vec3f w, Vec2f uv) {
  RGB Le = area_le(l, n, w);
  if (l.texture >= 0 && !is_black(Le)) Le = Le * texture_lookup(s.textures[l.texture], uv).rgb();
  return Le;
}
// Radiance of the environment arriving along -w (w points from the scene to the sky).
CHD RGB environment_radiance(const SceneView& s, const Light& l, Vec3f w) {
  if (l.texture >= 0) return l.L * envmap_eval(s.envmap, w);
  return l.L;
}
// Solid-angle density of sample_light choosing environment direction w.
CHD float environment_pdf(const SceneView& s, const Light& l, Vec3f w) {
  if (l.texture >= 0) return envmap_pdf(s.envmap, w);
  return uniform_sphere_pdf();
}

CHD float sphere_cos_theta_max(const Sphere& sp, Vec3f ref, bool& inside) {
  float d2 = length_sq(ref - sp.center);
  float r2 = sp.radius * sp.radius;
  inside = d2 <= r2 * 1.00001f;
  return inside ? -1.f : safe_sqrt(1.f - r2 / d2);
}

// Solid-angle density of sample_light choosing direction wi that reaches the
// light's surface at p_l with geometric normal n_l (area lights only).
CHD float light_pdf(const SceneView& s, const Light& l, Vec3f ref, Vec3f p_l, Vec3f n_l) {
  switch (l.type) {
    case LightType::kTriangle: {
      Vec3f p0, p1, p2;
      triangle_vertices(s, l.prim, p0, p1, p2);
      Vec3f d = p_l - ref;
      float d2 = length_sq(d);
      float c = absdot(n_l, d) / std::sqrt(d2);
      return c > 0.f ? d2 / (c * triangle_area(p0, p1, p2)) : 0.f;
    }
    case LightType::kSphere: {
      const Sphere& sp = s.spheres[l.prim - s.num_triangles];
      bool inside;
      float cos_max = sphere_cos_theta_max(sp, ref, inside);
      if (!inside) return uniform_cone_pdf(cos_max);
      Vec3f d = p_l - ref;
      float d2 = length_sq(d);
      float c = absdot(n_l, d) / std::sqrt(d2);
      return c > 0.f ? d2 / (c * 4.f * kPi * sp.radius * sp.radius) : 0.f;
    }
    case LightType::kEnvironment: return uniform_sphere_pdf();
    default: return 0.f;
  }
}

CHD bool sample_light(const SceneView& s, const Light& l, Vec3f ref, Vec2f u, LightSample& ls) {
  switch (l.type) {
    case LightType::kTriangle: {
      Vec3f p0, p1, p2;
      triangle_vertices(s, l.prim, p0, p1, p2);
      Vec2f b = square_to_uniform_triangle(u);
      Vec3f p = p0 * (1.f - b.x - b.y) + p1 * b.x + p2 * b.y;
      Vec3f n = normalize(cross(p1 - p0, p2 - p0));
      Vec3f d = p - ref;
      float d2 = length_sq(d);
      if (d2 == 0.f) return false;
      ls.dist = std::sqrt(d2);
      ls.wi = d / ls.dist;
      float c = absdot(n, ls.wi);
      if (c == 0.f) return false;
      ls.pdf = d2 / (c * triangle_area(p0, p1, p2));
      ls.uv_l = triangle_uv(s, l.prim, b.x, b.y);
      ls.Li = area_radiance(s, l, n, -ls.wi, ls.uv_l) * area_coverage(s, l.prim, ls.uv_l);
      ls.delta = false;
      ls.p_l = p;
      ls.n_l = n;
      return ls.pdf > 0.f && !is_black(ls.Li);
    }
    case LightType::kSphere: {
      const Sphere& sp = s.spheres[l.prim - s.num_triangles];
      bool inside;
      float cos_max = sphere_cos_theta_max(sp, ref, inside);
      Vec3f p, n;
      if (inside) {
        n = square_to_uniform_sphere(u);
        p = sp.center + n * sp.radius;
      } else {
        Vec3f axis = sp.center - ref;
        float dc = length(axis);
        Frame f(axis / dc);
        Vec3f w = f.to_world(square_to_uniform_cone(u, cos_max));
        // The point of the sphere along w (closest approach if grazing).
        float b = dot(axis, w);
        float disc = sp.radius * sp.radius - (dc * dc - b * b);
        float t = b - safe_sqrt(disc);
        p = ref + w * t;
        n = normalize(p - sp.center);
        p = sp.center + n * sp.radius;
      }
      Vec3f d = p - ref;
      float d2 = length_sq(d);
      if (d2 == 0.f) return false;
      ls.dist = std::sqrt(d2);
      ls.wi = d / ls.dist;
      ls.pdf = light_pdf(s, l, ref, p, n);
      ls.uv_l = sphere_uv_at(s, l.prim - s.num_triangles, n);
      ls.Li = area_radiance(s, l, n, -ls.wi, ls.uv_l) * area_coverage(s, l.prim, ls.uv_l);
      ls.delta = false;
      ls.p_l = p;
      ls.n_l = n;
      return ls.pdf > 0.f && !is_black(ls.Li);
    }
    case LightType::kPoint:
    case LightType::kSpot: {
      Vec3f d = l.p - ref;
      float d2 = length_sq(d);
      if (d2 == 0.f) return false;
      ls.dist = std::sqrt(d2);
      ls.wi = d / ls.dist;
      float falloff = l.type == LightType::kSpot ? spot_falloff(l, dot(-ls.wi, l.dir)) : 1.f;
      ls.Li = l.L * (falloff / d2);
      ls.pdf = 1.f;
      ls.delta = true;
      ls.p_l = l.p;
      ls.n_l = Vec3f(0.f);
      return falloff > 0.f;
    }
    case LightType::kDirectional: {
      ls.wi = -l.dir;
      ls.dist = kInf;
      ls.Li = l.L;
      ls.pdf = 1.f;
      ls.delta = true;
      return true;
    }
    case LightType::kEnvironment: {
      if (l.texture >= 0) {
        if (!envmap_sample(s.envmap, u, ls.wi, ls.pdf)) return false;
      } else {
        ls.wi = square_to_uniform_sphere(u);
        ls.pdf = uniform_sphere_pdf();
      }
      ls.dist = kInf;
      ls.Li = environment_radiance(s, l, ls.wi);
      ls.delta = false;
      return !is_black(ls.Li);
    }
  }
  return false;
}

}  // namespace caustica
