// The bidirectional integrators light, bdpt, bpm, vcm and upg (integrator/wavefront_vcm.h)
// instantiated on CudaBackend, in their own translation unit (cuda_wavefront.cuh says why).
#include "cuda_render.h"
#include "cuda_wavefront.cuh"

namespace caustica {

std::unique_ptr<WavefrontRenderer> make_cuda_vcm_wavefront(std::shared_ptr<Scene> scene, const VcmWavefrontParams& p,
                                                           int device) {
  return std::make_unique<CudaWavefront>(std::move(scene), device, [&](const CudaBackend& b, std::string name) {
    return std::make_unique<VcmWavefrontRenderer<CudaBackend>>(b, std::move(name), p);
  });
}

}  // namespace caustica
