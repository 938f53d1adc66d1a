// The CPU driver of `restir` (integrator/restir.h): direct light at each pixel's first non-delta vertex by
// ReSTIR DI (Bitterli et al. 2020), the rest by the path tracer. Each pass:
//   1. per pixel: the camera path (path.h's stages) to its shading point and on (emission, longer paths);
//      RIS over M light candidates at the shading point; temporal reuse of the previous pass's final
//      reservoir at the same pixel (confidence capped at history * M);
//   2. per pixel: spatial reuse of k neighbours' stage-1 reservoirs (read from a finished buffer), one shadow
//      ray to the resampled light point, the pixel's sample into the film;
//   3. the pass's shading points and final reservoirs become the next pass's history.
// Random numbers depend on (seed, pass, pixel, stage) only, so images do not depend on the thread count.
#pragma once
#include <atomic>
#include <memory>
#include <vector>

#include "render.h"

namespace caustica {

struct RestirVertex;
struct Reservoir;

class RestirIntegrator {
 public:
  RestirIntegrator(std::shared_ptr<Scene> scene, const RenderOptions& opt);
  ~RestirIntegrator();
  bool render_pass(int64_t pass, const std::atomic<bool>& cancel);
  std::vector<float> image() const { return film_.image(); }
  uint64_t rays() const { return rays_; }
  uint64_t shadow_rays() const { return shadow_rays_; }
  uint64_t invalid() const { return invalid_; }

 private:
  template <typename Accel>
  bool pass_with(const Accel& accel, int64_t pass, const std::atomic<bool>& cancel);
  std::shared_ptr<Scene> scene_;
  RenderOptions opt_;
  uint32_t max_depth_;
  int W_, H_;
  Film film_;
  uint64_t rays_ = 0, shadow_rays_ = 0, invalid_ = 0;
  // Per pixel: this pass's shading points and reservoirs after temporal reuse, the pass's path-traced
  // radiance and filter weight; the previous pass's shading points and final reservoirs.
  std::vector<RestirVertex> vert_, prev_vert_;
  std::vector<Reservoir> temporal_, prev_res_, final_;
  std::vector<RGB> path_L_;
  std::vector<float> weight_;
};

}  // namespace caustica
