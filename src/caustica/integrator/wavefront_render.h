// Host-side handle of a wavefront path tracer (integrator/wavefront_path.h) on some backend: what the
// render job drives. The CPU one is built here; the CUDA one lives in backend/cuda/ (cuda_render.h) so
// that nothing outside that folder needs CUDA headers.
#pragma once
#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "../scene/scene.h"
#include "path.h"

namespace caustica {

struct WavefrontOptions {
  bool compaction = true;
  bool sort_materials = false;
  bool cache_first_bounce = false;  // only when camera rays repeat: no pixel jitter, no lens (caller checks)
};

struct WavefrontPassStats {
  uint64_t rays = 0, shadow_rays = 0, invalid = 0;
};

class WavefrontRenderer {
 public:
  virtual ~WavefrontRenderer() = default;
  // Adds sample `sample_index` of every pixel to the film; false when cancelled midway (film unchanged).
  virtual bool render_pass(uint32_t sample_index, const std::atomic<bool>* cancel, WavefrontPassStats& stats) = 0;
  // The film's sums (r, g, b, weight per pixel) over all passes and over the odd passes (render.h's Film).
  virtual void film(std::vector<double>& sum, std::vector<double>& odd) const = 0;
  virtual std::string device_name() const = 0;
};

// The wavefront on the CPU backend: Embree (use_embree) or the portable BVH for ray queries.
std::unique_ptr<WavefrontRenderer> make_cpu_wavefront(std::shared_ptr<Scene> scene, const PathParams& pp,
                                                      const WavefrontOptions& opt, bool use_embree);

}  // namespace caustica
