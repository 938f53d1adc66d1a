#include "wavefront_render.h"

#include "../backend/cpu/cpu_accel.h"
#include "../backend/cpu/cpu_backend.h"
#include "wavefront_renderers.h"

namespace caustica {

namespace {

// Owns the CPU backend (the scene's arrays and its accelerator) for the renderer built over it.
class CpuWavefront final : public OwningRenderer {
 public:
  template <class Make>
  CpuWavefront(std::shared_ptr<Scene> scene, const CpuAccel* accel, Make make)
      : scene_(std::move(scene)), backend_(scene_->view(), accel) {
    inner_ = make(backend_, "cpu (wavefront, " + std::string(accel ? accel->name() : "portable BVH") + ")");
  }
  ~CpuWavefront() override { inner_.reset(); }  // before the backend it refers to

 private:
  std::shared_ptr<Scene> scene_;
  CpuBackend backend_;
};

}  // namespace

std::unique_ptr<WavefrontRenderer> make_cpu_wavefront(std::shared_ptr<Scene> scene, const PathParams& pp,
                                                      const WavefrontOptions& opt, const CpuAccel* accel) {
  const uint32_t materials = uint32_t(scene->materials.size());
  return std::make_unique<CpuWavefront>(std::move(scene), accel, [&](const CpuBackend& b, std::string name) {
    return std::make_unique<PathWavefrontRenderer<CpuBackend>>(b, std::move(name), pp, opt, materials);
  });
}

std::unique_ptr<WavefrontRenderer> make_cpu_photon_wavefront(std::shared_ptr<Scene> scene,
                                                             const PhotonWavefrontParams& p, const CpuAccel* accel) {
  return std::make_unique<CpuWavefront>(std::move(scene), accel, [&](const CpuBackend& b, std::string name) {
    return std::make_unique<PhotonWavefrontRenderer<CpuBackend>>(b, std::move(name), p);
  });
}

std::unique_ptr<WavefrontRenderer> make_cpu_vcm_wavefront(std::shared_ptr<Scene> scene, const VcmWavefrontParams& p,
                                                          const CpuAccel* accel) {
  return std::make_unique<CpuWavefront>(std::move(scene), accel, [&](const CpuBackend& b, std::string name) {
    return std::make_unique<VcmWavefrontRenderer<CpuBackend>>(b, std::move(name), p);
  });
}

std::unique_ptr<WavefrontRenderer> make_cpu_restir_wavefront(std::shared_ptr<Scene> scene,
                                                             const RestirWavefrontParams& p, const CpuAccel* accel) {
  return std::make_unique<CpuWavefront>(std::move(scene), accel, [&](const CpuBackend& b, std::string name) {
    return std::make_unique<RestirWavefrontRenderer<CpuBackend>>(b, std::move(name), p);
  });
}

}  // namespace caustica
