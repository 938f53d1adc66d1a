#include "wavefront_render.h"

#include "../backend/cpu/cpu_backend.h"
#include "wavefront_path.h"

namespace caustica {

namespace {

class CpuWavefront final : public WavefrontRenderer {
 public:
  CpuWavefront(std::shared_ptr<Scene> scene, const PathParams& pp, const WavefrontOptions& opt, bool use_embree)
      : scene_(std::move(scene)),
        backend_(scene_->view(), use_embree ? &scene_->embree() : nullptr),
        wf_(backend_, pp, opt, uint32_t(scene_->materials.size())),
        use_embree_(use_embree) {}
  bool render_pass(uint32_t sample_index, const std::atomic<bool>* cancel, WavefrontPassStats& stats) override {
    return wf_.render_pass(sample_index, cancel, stats);
  }
  void film(std::vector<double>& sum, std::vector<double>& odd) const override { wf_.film(sum, odd); }
  std::string device_name() const override { return use_embree_ ? "cpu (wavefront, embree)" : "cpu (wavefront, portable BVH)"; }

 private:
  std::shared_ptr<Scene> scene_;
  CpuBackend backend_;
  WavefrontPath<CpuBackend> wf_;
  bool use_embree_;
};

}  // namespace

std::unique_ptr<WavefrontRenderer> make_cpu_wavefront(std::shared_ptr<Scene> scene, const PathParams& pp,
                                                      const WavefrontOptions& opt, bool use_embree) {
  return std::make_unique<CpuWavefront>(std::move(scene), pp, opt, use_embree);
}

}  // namespace caustica
