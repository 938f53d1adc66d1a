// The CPU driver of `upg` (integrator/upg.h): unbiased photon gathering combined
// with BDPT. Each pass traces one light subpath per pixel in fixed chunks (as
// vcm_render.cpp: vertices and light-tracing splats concatenated and applied in
// chunk order), builds the hash grid of light vertices, then one camera subpath
// per pixel with BDPT's strategies (connections to the light subpath of the same
// index) and, at every eye hit after a non-delta vertex, the gather of all light
// vertices within the fixed radius with the trial estimate of 1/P (in scenes with media at surface vertices,
// with free-flight sampling in the trials: upg.h). Random
// numbers depend on (seed, pass, pixel / subpath index, vertex, photon) only, so
// images do not depend on the thread count.
#pragma once
#include <atomic>
#include <memory>
#include <vector>

#include "render.h"

namespace caustica {

class UpgIntegrator {
 public:
  UpgIntegrator(std::shared_ptr<Scene> scene, const RenderOptions& opt);
  bool render_pass(int64_t pass, const std::atomic<bool>& cancel);
  std::vector<float> image(int64_t passes_done) const;
  float radius() const { return r_; }
  uint64_t photons_traced() const { return traced_; }
  uint64_t rays() const { return rays_; }
  uint64_t trials() const { return trials_; }        // trial rays traced for 1/P
  uint64_t capped() const { return capped_; }        // gathers whose trials reached the cap

 private:
  std::shared_ptr<Scene> scene_;
  RenderOptions opt_;
  uint32_t max_depth_;
  float r_ = 0.f;
  int32_t outer_medium_ = -1;  // where light subpaths start when their first ray meets no medium boundary
  int W_, H_;
  uint64_t traced_ = 0, rays_ = 0, trials_ = 0, capped_ = 0;
  std::vector<double> sum_;
};

}  // namespace caustica
