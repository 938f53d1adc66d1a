// Emission sampling for photon tracing: a ray leaving a light with its flux
// weight Le cos / (pdf_pos pdf_dir) (pbrt-v4 Sec. 12.x "SampleLe"; Jensen 2001
// Ch. 5 photon emission). Area lights emit cosine-weighted from a uniformly
// chosen point; point lights uniformly over the sphere; spot lights uniformly
// in their cone; directional and environment lights from a disk of the scene's
// bounding radius perpendicular to the direction of travel.
#pragma once
#include "../base/sampling.h"
#include "light_sample.h"
#include "light.h"

namespace caustica {

struct EmitSample {
  Ray ray;
  RGB weight{0.f};  // flux carried by the photon, before dividing by the light's selection pmf
  Vec3f n{0.f};     // surface normal of area lights (offset direction), zero otherwise
};


// Emission from a directional or environment light: a direction (the light's, or for an environment one
// sampled from the map or uniformly; dir_pdf per solid angle, 1 for directional), and an origin uniform on
// the disk of the scene's bounding sphere facing it, one radius behind the sphere's centre.
CHD bool sample_infinite_emission(const SceneView& s, const Light& l, Vec2f u_pos, Vec2f u_dir, Ray& ray,
                                  float& dir_pdf) {
  const float R = s.bsphere_radius;
  Vec3f dir = l.dir;
  dir_pdf = 1.f;
  if (l.type == LightType::kEnvironment) {
    Vec3f w;  // towards the sky; the light travels along -w
    if (l.texture >= 0) {
      if (!envmap_sample(s.envmap, u_dir, w, dir_pdf)) return false;
    } else {
      w = square_to_uniform_sphere(u_dir);
      dir_pdf = uniform_sphere_pdf();
    }
    dir = -w;
  }
  Frame f(dir);
  Vec2f d = square_to_concentric_disk(u_pos) * R;
  ray = Ray{s.bsphere_center + f.to_world(Vec3f(d.x, d.y, -R)), dir, kInf};
  return true;
}

CHD bool sample_emission(const SceneView& s, const Light& l, Vec2f u_pos, Vec2f u_dir, float u_side, EmitSample& e) {
  const float R = s.bsphere_radius;
  switch (l.type) {
    case LightType::kTriangle:
    case LightType::kSphere: {
      Vec3f p, n;
      Vec2f uv;
      float area;
      if (l.type == LightType::kTriangle) {
        Vec3f p0, p1, p2;
        triangle_vertices(s, l.prim, p0, p1, p2);
        Vec2f b = square_to_uniform_triangle(u_pos);
        p = p0 * (1.f - b.x - b.y) + p1 * b.x + p2 * b.y;
        n = normalize(cross(p1 - p0, p2 - p0));
        area = triangle_area(p0, p1, p2);
        uv = triangle_uv(s, l.prim, b.x, b.y);
      } else {
        const Sphere& sp = s.spheres[l.prim - s.num_triangles];
        n = square_to_uniform_sphere(u_pos);
        p = sp.center + n * sp.radius;
        area = 4.f * kPi * sp.radius * sp.radius;
        uv = sphere_uv_at(s, l.prim - s.num_triangles, n);
      }
      float sides = 1.f;
      if (l.two_sided) {
        sides = 2.f;
        if (u_side < 0.5f) n = -n;
      }
      Vec3f d = Frame(n).to_world(square_to_cosine_hemisphere(u_dir));
      e.ray.o = offset_ray_origin(p, n, n);
      e.ray.d = d;
      e.ray.tmax = kInf;
      e.n = n;
      RGB Le = l.L * area_coverage(s, l.prim, uv);
      if (l.texture >= 0) Le = Le * texture_lookup(s.textures[l.texture], uv).rgb();
      e.weight = Le * (kPi * area * sides);  // Le cos / (1/A * cos/pi) per side
      return !is_black(e.weight);
    }
    case LightType::kPoint:
      e.ray.o = l.p;
      e.ray.d = square_to_uniform_sphere(u_dir);
      e.ray.tmax = kInf;
      e.weight = l.L * (4.f * kPi);
      return true;
    case LightType::kSpot: {
      Vec3f w = square_to_uniform_cone(u_dir, l.cos_total);
      e.ray.o = l.p;
      e.ray.d = Frame(l.dir).to_world(w);
      e.ray.tmax = kInf;
      e.weight = l.L * (spot_falloff(l, w.z) / uniform_cone_pdf(l.cos_total));
      return true;
    }
    case LightType::kDirectional:
    case LightType::kEnvironment: {
      float dir_pdf;
      if (!sample_infinite_emission(s, l, u_pos, u_dir, e.ray, dir_pdf)) return false;
      Vec3f dir = e.ray.d;
      float disk = kPi * R * R;
      e.weight = l.type == LightType::kDirectional ? l.L * disk
                                                   : environment_radiance(s, l, -dir) * (disk / dir_pdf);
      return !is_black(e.weight);
    }
  }
  return false;
}

}  // namespace caustica
