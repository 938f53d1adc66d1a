// Compile check of the stage functions that do not run on the CUDA backend yet (the path tracer does:
// integrator/wavefront_path.h on cuda_backend.cuh): photon tracing, the photon gather, and the
// bidirectional and unbiased-gathering stages, as kernels traversing the portable BVH. Compiled into the
// CUDA build (nvcc, warnings as errors) so that device code cannot rot before its driver exists.
#include "../../integrator/vcm.h"
#include "../../integrator/upg.h"
#include "../../photon/hash_grid.h"
#include "../../photon/trace.h"
#include "../../scene/intersect.h"

namespace caustica {

// Photon tracing with the portable BVH: one thread per photon path, stored
// photons appended through an atomic counter (order fixed later by the grid's sort).
__global__ void k_trace_photons(SceneView s, uint64_t seed, uint32_t pass, uint32_t count, uint32_t max_depth,
                                Photon* out, uint32_t capacity, uint32_t* n_out) {
  uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  trace_photon(
      s, seed, pass, i, max_depth, [&](const Ray& r, Hit& h) { return scene_intersect(s, r, h); },
      [&](const Photon& ph) {
        uint32_t k = atomicAdd(n_out, 1u);
        if (k < capacity) out[k] = ph;
      });
}

// Photon gather at visible points from the sorted hash grid (Hachisuka & Jensen 2010).
__global__ void k_gather(SceneView s, PhotonGridView grid, const Vec3f* points, const uint32_t* materials,
                         const Vec3f* normals, const Vec3f* wo, const float* radius, float3* flux, uint32_t n) {
  uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const Material& m = s.materials[materials[i]];
  Frame frame(normals[i]);
  Vec3f wol = frame.to_local(wo[i]);
  RGB phi(0.f);
  grid.query(points[i], radius[i], [&](const Photon& ph) { phi += bsdf_eval(m, wol, frame.to_local(ph.wi)) * ph.power; });
  flux[i] = make_float3(phi.x, phi.y, phi.z);
}

// Unbiased photon gathering stages (integrator/upg.h): one gathered photon per thread
// (connection share, shadow test, trials from the previous eye vertex).
__global__ void k_upg_gather(SceneView s, VcmParams p, const VcmPathState* prev, const VcmLightVertex* photons,
                             uint32_t n, float3* out) {
  uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  PCG32 rng = upg_trial_rng(p, i, prev[i].length, i);
  UpgGather g;
  upg_gather(s, p, prev[i], photons[i], rng.next_float(), g);
  RGB L(0.f);
  if (g.active && !scene_occluded(s, g.conn.ray)) {
    uint32_t cast = 0;
    float inv_p = upg_inv_p(p, prev[i], photons[i].sh.p, rng, cast, [&](const Ray& r) {
      Hit h;
      scene_intersect(s, r, h);
      return upg_trial_lands(s, p, r, h, photons[i].sh.p);
    });
    L = g.conn.contrib * inv_p;
  }
  VcmShadow sr;
  vcm_camera_connect(s, p, prev[i], photons[i], sr);
  if (sr.active) L += sr.contrib;
  out[i] = make_float3(L.x, L.y, L.z);
}

// Bidirectional stages (integrator/vcm.h): one light subpath per thread up to
// its vertices and splats, then camera subpaths with connections and merges.
__global__ void k_vcm_light(SceneView s, VcmParams p, uint32_t n, VcmLightVertex* vertices, uint32_t capacity,
                            uint32_t* n_vertices, VcmSplat* splats, uint32_t* n_splats) {
  uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  VcmPathState st;
  vcm_light_start(s, p, i, st);
  while (st.active) {
    Hit hit;
    scene_intersect(s, st.ray, hit);
    VcmLightVertex v;
    if (vcm_light_hit(s, p, st, hit, v)) {
      uint32_t k = atomicAdd(n_vertices, 1u);
      if (k < capacity) vertices[k] = v;
    }
    if (!st.active) break;
    VcmSplat sp;
    vcm_light_to_camera(s, p, st, sp);
    if (sp.active && !scene_occluded(s, sp.ray)) {
      uint32_t k = atomicAdd(n_splats, 1u);
      if (k < capacity) splats[k] = sp;
    }
    vcm_light_continue(p, st);
  }
}

__global__ void k_vcm_camera(SceneView s, VcmParams p, const VcmLightVertex* vertices, const uint32_t* path_start,
                             PhotonGridView grid, const VcmMergeVertex* merge_vertices, float3* out) {
  uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  uint32_t n = uint32_t(s.camera.width) * uint32_t(s.camera.height);
  if (i >= n) return;
  VcmPathState st;
  vcm_camera_start(s, p, i % uint32_t(s.camera.width), i / uint32_t(s.camera.width), st);
  while (st.active) {
    Hit hit;
    scene_intersect(s, st.ray, hit);
    vcm_camera_hit(s, p, st, hit);
    if (!st.active) break;
    VcmShadow sr;
    vcm_camera_nee(s, p, st, sr);
    if (sr.active) vcm_shadow(st, sr, scene_occluded(s, sr.ray));
    for (uint32_t k = path_start[i]; k < path_start[i + 1]; ++k) {
      vcm_camera_connect(s, p, st, vertices[k], sr);
      if (sr.active) vcm_shadow(st, sr, scene_occluded(s, sr.ray));
    }
    vcm_camera_merge(s, p, st, grid, merge_vertices);
    vcm_camera_continue(p, st);
  }
  out[i] = make_float3(st.L.x, st.L.y, st.L.z);
}

}  // namespace caustica
