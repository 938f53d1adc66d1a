// The renderable scene as flat arrays and plain structs: what every
// integrator reads, on the CPU and (copied to device memory) on the GPU.
// Primitive ids: triangles 0 .. num_triangles-1, then spheres.
#pragma once
#include <cstdint>
#include "../camera/camera.h"
#include "../film/filter.h"
#include "../geometry/bvh.h"
#include "../geometry/shapes.h"
#include "../light/envmap.h"
#include "../light/light.h"
#include "../light/light_bvh.h"
#include "../texture/texture.h"
#include "../material/material.h"
#include "../medium/medium.h"
#include "../medium/medium_grid.h"

namespace caustica {

// Power-proportional light selection with Walker's alias method (Walker 1977;
// Vose 1991 construction on the host): O(1) sampling from one uniform number.
struct LightSamplerView {
  const float* prob = nullptr;     // acceptance probability of each bucket
  const uint32_t* alias = nullptr; // the alternative of each bucket
  const float* pmf = nullptr;      // selection probability of each light
  uint32_t count = 0;

  CHD uint32_t sample(float u, float& pmf_out) const {
    Vec2f v(u, 0.f);
    return sample_reuse(v, pmf_out);
  }
  // The same choice from u.x, with u.x then remapped to a fresh uniform number
  // in [0, 1): the part of the bucket that chose the light, stretched to the
  // unit interval (sample reuse, as Mitsuba's emitter selection does). A
  // stratified 2D point set thus stays stratified on each chosen light, instead
  // of the light's point being decorrelated from its choice by a separate
  // dimension.
  CHD uint32_t sample_reuse(Vec2f& u, float& pmf_out) const {
    float x = u.x * float(count);
    uint32_t i = x >= float(count) ? count - 1 : uint32_t(x);
    float frac = minf(x - float(i), kOneMinusEpsilon);  // u.x * count may round up to count
    float p = prob[i];
    uint32_t l;
    float r;
    if (frac < p) {
      l = i;
      r = frac / p;
    } else {
      l = alias[i];
      r = (frac - p) / (1.f - p);
    }
    u.x = minf(r, kOneMinusEpsilon);
    pmf_out = pmf[l];
    return l;
  }
};

struct SceneView {
  // Triangles
  const Vec3f* positions = nullptr;
  const Vec3f* normals = nullptr;  // per vertex, or null
  const Vec2f* uvs = nullptr;      // per vertex, or null (then uv = barycentrics (b1, b2))
  const Tangent* tangents = nullptr;  // per vertex, or null (then the triangles' dp/du: shading.h)
  const RGB* colors = nullptr;        // per vertex linear RGB, or null (materials with kVertexColor: shading.h)
  const uint32_t* indices = nullptr;  // 3 per triangle
  uint32_t num_triangles = 0;
  // Spheres
  const Sphere* spheres = nullptr;
  uint32_t num_spheres = 0;
  // Per sphere, or null when none is rotated: the sphere's own axes in world space (its transform's rotation,
  // or reflection), in which its UVs are measured (sphere_uv_at in interaction.h).
  const Frame* sphere_frames = nullptr;
  // Per primitive
  const uint32_t* prim_material = nullptr;
  const int32_t* prim_light = nullptr;  // light index of an emissive primitive, else -1
  // Non-zero when some material has kAlphaTested: then the intersection queries test opacity (scene/opacity.h).
  uint32_t alpha_tested = 0;
  // Participating media (medium/medium.h): the media, each primitive's interface (null when no shape has
  // one), the medium the camera is in (-1: vacuum), and whether any material is kNull.
  const Medium* media = nullptr;
  uint32_t num_media = 0;
  const MediumInterface* prim_medium = nullptr;
  int32_t camera_medium = -1;
  // The density grids of heterogeneous media (Medium::grid; medium/medium_grid.h) and their samples.
  const MediumGrid* medium_grids = nullptr;
  const float* grid_values = nullptr;
  uint32_t has_null = 0;
  // Shading
  const Material* materials = nullptr;
  // kSheenRows sheen albedo tables (material/metallic_roughness.h, mr_sheen_table_at), or null where no material
  // has a sheen roughness texture.
  const uint16_t* sheen_table = nullptr;
  const Light* lights = nullptr;
  uint32_t num_lights = 0;
  uint32_t num_point_lights = 0;  // point and spot lights (equiangular sampling in media, integrator/path.h)
  LightSamplerView light_sampler;
  LightBvhView light_bvh;  // the spatial light selection (--light-sampler bvh; light/light_bvh.h)
  int32_t environment_light = -1;  // index into lights, or -1
  const TextureView* textures = nullptr;
  uint32_t num_textures = 0;
  EnvMapView envmap;  // the environment light's map when its Light::texture >= 0
  Camera camera;
  Filter filter;  // the pixel filter (film/filter.h)
  Bounds3 bounds;
  Vec3f bsphere_center;
  float bsphere_radius = 1.f;
  BVHView bvh;  // the portable BVH (always built; CPU default traversal is Embree)
};

// Whether paths in this scene can meet media or null surfaces (only the path tracer renders those).
CHD bool scene_has_media(const SceneView& s) {
  return s.prim_medium != nullptr || s.camera_medium >= 0 || s.has_null != 0;
}

// The light that next-event estimation from reference point p chooses: by power (the alias table), or with bvh
// by the light BVH's importance from p (light/light_bvh.h). u.x chooses and is then remapped to a fresh uniform
// number (sample_reuse); its probability goes to pmf. -1: no light can reach p (the BVH only).
CHD int32_t choose_light(const SceneView& s, bool bvh, Vec3f p, Vec2f& u, float& pmf) {
  return bvh ? light_bvh_sample(s.light_bvh, p, u, pmf) : int32_t(s.light_sampler.sample_reuse(u, pmf));
}

}  // namespace caustica
