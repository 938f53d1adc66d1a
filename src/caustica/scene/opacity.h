// Opacity (cut-outs) inside the ray queries, as pbrt-v4 tests a shape's alpha during intersection (pbrt-v4
// Sec. 6.5.3, Triangle::Intersect): a candidate hit on a material with kAlphaTested is kept or skipped before
// it can end the ray, in the portable BVH (scene/intersect.h) and in Embree's filter functions
// (backend/cpu/cpu_accel.cpp). An alpha test (opacity_cutoff >= 0) keeps the hit where the opacity reaches the
// cutoff. Otherwise the hit is kept with probability `opacity` (stochastic transparency, Enderton et al. 2010,
// "Stochastic Transparency"): the decision is a hash of the ray and the primitive, so the same query always
// gets the same answer (on any thread, CPU or GPU), and two surfaces along one ray decide independently
// (pbrt-v4 hashes the ray alone, which makes stacked layers pass or block together).
//
// Expected values: a ray crosses such a surface with probability 1 - opacity, so its transmittance is right
// for camera rays, shadow rays and photons alike. A light sample on an emitter with opacity is weighted by the
// same probability (area_coverage), which is what the hits that reach it see on average.
#pragma once
#include "../base/rng.h"
#include "interaction.h"

namespace caustica {

// The material's opacity at texture coordinates uv, before the cutoff: opacity x the texture's alpha (or
// luminance), clamped to [0, 1].
CHD float material_opacity(const SceneView& s, const Material& m, Vec2f uv) {
  float a = m.opacity;
  if (m.tex_opacity >= 0) {
    RGBA c = texture_lookup(s.textures[m.tex_opacity], uv);
    a *= (m.flags & kOpacityLuminance) ? 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b : c.a;
  }
  return clampf(a, 0.f, 1.f);
}

// The probability that a ray stops at the surface there: 0 or 1 under an alpha test, else the opacity.
CHD float material_coverage(const SceneView& s, const Material& m, Vec2f uv) {
  float a = material_opacity(s, m, uv);
  if (m.opacity_cutoff >= 0.f) return a >= m.opacity_cutoff ? 1.f : 0.f;
  return a;
}

// A uniform number in [0, 1) from the ray and the candidate (prim, and which of a sphere's two crossings).
CHD float opacity_hash(const Ray& r, uint32_t prim, uint32_t crossing) {
  uint64_t a = (uint64_t(float_bits(r.o.x)) << 32) | float_bits(r.o.y);
  uint64_t b = (uint64_t(float_bits(r.o.z)) << 32) | float_bits(r.d.x);
  uint64_t c = (uint64_t(float_bits(r.d.y)) << 32) | float_bits(r.d.z);
  uint64_t h = hash3(a, b ^ (uint64_t(prim) << 1 | crossing), c);
  return u32_to_unit_float(uint32_t(h >> 32));
}

// Whether a ray stops at the candidate hit on primitive `prim` with texture coordinates uv.
CHD bool opacity_keeps(const SceneView& s, const Material& m, Vec2f uv, const Ray& r, uint32_t prim,
                       uint32_t crossing) {
  float a = material_opacity(s, m, uv);
  if (m.opacity_cutoff >= 0.f) return a >= m.opacity_cutoff;
  if (a >= 1.f) return true;
  if (a <= 0.f) return false;
  return opacity_hash(r, prim, crossing) < a;
}

CHD bool triangle_hit_kept(const SceneView& s, uint32_t tri, float b1, float b2, const Ray& r) {
  const Material& m = s.materials[s.prim_material[tri]];
  if (!(m.flags & kAlphaTested)) return true;
  return opacity_keeps(s, m, triangle_uv(s, tri, b1, b2), r, tri, 0);
}

// The nearest crossing of sphere i (primitive num_triangles + i) in (0, r.tmax) that opacity keeps:
// intersect_sphere's answer on opaque spheres; on others the far crossing when the near one is skipped.
CHD bool intersect_sphere_kept(const SceneView& s, uint32_t i, const Ray& r, float& t_out) {
  const Sphere& sp = s.spheres[i];
  const uint32_t prim = s.num_triangles + i;
  if (!s.alpha_tested || !(s.materials[s.prim_material[prim]].flags & kAlphaTested))
    return intersect_sphere(r, sp, t_out);
  const Material& m = s.materials[s.prim_material[prim]];
  float t0, t1;
  if (!sphere_roots(r, sp, t0, t1)) return false;
  auto keeps = [&](float t, uint32_t crossing) {
    Vec3f n = normalize(r.o + r.d * t - sp.center);
    return opacity_keeps(s, m, sphere_uv_at(s, i, n), r, prim, crossing);
  };
  if (sphere_near_root_ok(r, sp, t0) && keeps(t0, 0)) {
    t_out = t0;
    return true;
  }
  if (t0 >= r.tmax) return false;
  if (!(t1 > 0.f) || !(t1 < r.tmax) || !keeps(t1, 1)) return false;
  t_out = t1;
  return true;
}

// The coverage of an area light's primitive at uv (1 when its material has no opacity): what a light sample
// there is weighted by.
CHD float area_coverage(const SceneView& s, uint32_t prim, Vec2f uv) {
  if (!s.alpha_tested) return 1.f;
  const Material& m = s.materials[s.prim_material[prim]];
  return (m.flags & kAlphaTested) ? material_coverage(s, m, uv) : 1.f;
}

}  // namespace caustica
