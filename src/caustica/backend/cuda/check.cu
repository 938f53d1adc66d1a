// Compile check of the stage functions that do not run on the CUDA backend yet (the path tracer, sppm and
// pppm do: integrator/wavefront_path.h, wavefront_photon.h on cuda_backend.cuh): the bidirectional and
// unbiased-gathering stages, as kernels traversing the portable BVH. Compiled into the
// CUDA build (nvcc, warnings as errors) so that device code cannot rot before its driver exists.
#include "../../integrator/vcm.h"
#include "../../integrator/upg.h"
#include "../../photon/hash_grid.h"
#include "../../photon/trace.h"
#include "../../scene/intersect.h"

namespace caustica {

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
