// The CUDA entry points of a build without the CUDA backend (CMake CAUSTICA_CUDA=OFF).
#include "../../base/error.h"
#include "cuda_render.h"

namespace caustica {

bool cuda_built() { return false; }

namespace {
[[noreturn]] void no_cuda() {
  throw InputError("device 'cuda' is not available: this build of caustica has no CUDA backend");
}
}  // namespace

std::vector<CudaDeviceInfo> cuda_devices(std::string* why) {
  if (why) *why = "this build of caustica has no CUDA backend (configure with -DCAUSTICA_CUDA=ON)";
  return {};
}

std::unique_ptr<WavefrontRenderer> make_cuda_wavefront(std::shared_ptr<Scene>, const PathParams&,
                                                       const WavefrontOptions&, int) {
  no_cuda();
}

std::unique_ptr<WavefrontRenderer> make_cuda_photon_wavefront(std::shared_ptr<Scene>, const PhotonWavefrontParams&,
                                                              int) {
  no_cuda();
}

std::unique_ptr<WavefrontRenderer> make_cuda_vcm_wavefront(std::shared_ptr<Scene>, const VcmWavefrontParams&, int) {
  no_cuda();
}

std::unique_ptr<WavefrontRenderer> make_cuda_restir_wavefront(std::shared_ptr<Scene>, const RestirWavefrontParams&,
                                                              int) {
  no_cuda();
}

double cuda_trace_rays(const Scene&, const std::vector<Ray>&, bool, std::vector<Hit>&, int, int) { no_cuda(); }

}  // namespace caustica
