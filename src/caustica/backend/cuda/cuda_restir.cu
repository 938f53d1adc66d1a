// ReSTIR (integrator/wavefront_restir.h) instantiated on CudaBackend, in its own translation unit
// (cuda_wavefront.cuh says why).
#include "cuda_render.h"
#include "cuda_wavefront.cuh"

namespace caustica {

std::unique_ptr<WavefrontRenderer> make_cuda_restir_wavefront(std::shared_ptr<Scene> scene,
                                                              const RestirWavefrontParams& p, int device) {
  return std::make_unique<CudaWavefront>(std::move(scene), device, [&](const CudaBackend& b, std::string name) {
    return std::make_unique<RestirWavefrontRenderer<CudaBackend>>(b, std::move(name), p);
  });
}

}  // namespace caustica
