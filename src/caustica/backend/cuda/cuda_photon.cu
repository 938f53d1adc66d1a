// The photon integrators sppm, ppm, pppm and pm (integrator/wavefront_photon.h) instantiated on
// CudaBackend, in their own translation unit (cuda_wavefront.cuh says why).
#include "cuda_render.h"
#include "cuda_wavefront.cuh"

namespace caustica {

std::unique_ptr<WavefrontRenderer> make_cuda_photon_wavefront(std::shared_ptr<Scene> scene,
                                                              const PhotonWavefrontParams& p, int device) {
  return std::make_unique<CudaWavefront>(std::move(scene), device, [&](const CudaBackend& b, std::string name) {
    return std::make_unique<PhotonWavefrontRenderer<CudaBackend>>(b, std::move(name), p);
  });
}

}  // namespace caustica
