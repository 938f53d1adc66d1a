// Compile check of the stage functions that do not run on the CUDA backend yet (the path tracer, sppm,
// pppm, light, bdpt, bpm and vcm do: integrator/wavefront_path.h, wavefront_photon.h, wavefront_vcm.h on
// cuda_backend.cuh): the unbiased-gathering stages, as a kernel traversing the portable BVH. Compiled into
// the CUDA build (nvcc, warnings as errors) so that device code cannot rot before its driver exists.
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

}  // namespace caustica
