// The wavefront path tracer (integrator/wavefront_path.h) instantiated on CudaBackend, in its own
// translation unit (cuda_wavefront.cuh says why).
#include "cuda_render.h"
#include "cuda_wavefront.cuh"

namespace caustica {

std::unique_ptr<WavefrontRenderer> make_cuda_wavefront(std::shared_ptr<Scene> scene, const PathParams& pp,
                                                       const WavefrontOptions& opt, int device) {
  const uint32_t materials = uint32_t(scene->materials.size());
  return std::make_unique<CudaWavefront>(std::move(scene), device, [&](const CudaBackend& b, std::string name) {
    return std::make_unique<PathWavefrontRenderer<CudaBackend>>(b, std::move(name), pp, opt, materials);
  });
}

}  // namespace caustica
