// Host-side handle of a wavefront path tracer (integrator/wavefront_path.h) on some backend: what the
// render job drives. The CPU one is built here; the CUDA one lives in backend/cuda/ (cuda_render.h) so
// that nothing outside that folder needs CUDA headers.
#pragma once
#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "../photon/adaptive.h"
#include "../scene/scene.h"
#include "path.h"
#include "restir.h"
#include "vcm.h"

namespace caustica {

struct WavefrontOptions {
  bool compaction = true;
  bool sort_materials = false;
  bool cache_first_bounce = false;  // only when camera rays repeat: no pixel jitter, no lens (caller checks)
};

struct WavefrontPassStats {
  uint64_t rays = 0, shadow_rays = 0, invalid = 0, photons = 0;
  // Photon integrators: wall-clock seconds of the pass's stages (the backend synchronised after each).
  double seconds_visible = 0.0, seconds_photons = 0.0, seconds_grid = 0.0, seconds_gather = 0.0;
  // Bidirectional integrators: light subpaths, the merge/gather grid (seconds_grid), camera subpaths,
  // accumulation.
  double seconds_light = 0.0, seconds_camera = 0.0, seconds_accumulate = 0.0;
  uint64_t stored_photons = 0;  // photons in the grid's input (before stochastic hashing); light vertices
};

// The wall-clock seconds of a wavefront pass's stages: lap(seconds) synchronises the backend and stores the
// time since the previous lap (or since the clock was made).
template <class B>
struct StageClock {
  explicit StageClock(const B& backend) : b(backend) {}
  void lap(double& seconds) {
    b.synchronize();
    const auto t = std::chrono::steady_clock::now();
    seconds = std::chrono::duration<double>(t - t0).count();
    t0 = t;
  }
  const B& b;
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
};

// A render on a backend, pass by pass: the path tracer (wavefront_path.h), sppm/ppm/pppm/pm (wavefront_photon.h)
// or light/bdpt/bpm/vcm (wavefront_vcm.h).
class WavefrontRenderer {
 public:
  virtual ~WavefrontRenderer() = default;
  // Renders pass `pass` (0-based); false when cancelled midway (the image is then unchanged).
  virtual bool render_pass(uint32_t pass, const std::atomic<bool>* cancel, WavefrontPassStats& stats) = 0;
  // The image after `passes` complete passes (H*W*3).
  virtual std::vector<float> image(int64_t passes) const = 0;
  // Path tracer only: the film's sums (r, g, b, weight per pixel) over all passes and over the odd passes
  // (render.h's Film), for the noise estimate; false for the photon integrators.
  virtual bool film(std::vector<double>& sum, std::vector<double>& odd) const {
    (void)sum;
    (void)odd;
    return false;
  }
  virtual std::string device_name() const = 0;
  virtual float initial_radius() const { return 0.f; }  // photon integrators
  // sppm, ppm, pppm with --photon-sampling adaptive: the chains' figures over the complete passes.
  virtual AdaptiveSummary adaptive_summary() const { return AdaptiveSummary(); }
};

// The wavefront on the CPU backend: `accel` (one of the scene's CPU accelerators) or, where null, the portable
// BVH for ray queries.
std::unique_ptr<WavefrontRenderer> make_cpu_wavefront(std::shared_ptr<Scene> scene, const PathParams& pp,
                                                      const WavefrontOptions& opt, const CpuAccel* accel);

// What the photon wavefront needs beyond the scene (RenderOptions of sppm / ppm / pppm / pm, resolved).
struct PhotonWavefrontParams {
  bool pppm = false;           // pppm (global radius per pass)
  bool ppm = false;            // ppm (fixed measurement points)
  bool pm = false;             // pm (Jensen's global and caustic maps, k nearest); none of the three: sppm
  uint32_t k = 50;             // pm: photons per estimate (at most kWavefrontMaxK, pm.h)
  uint64_t seed = 0;
  SamplerType sampler = SamplerType::kSobol;
  uint32_t max_depth = 0xffffffffu;  // segments, Mitsuba's count
  uint32_t photons = 0;        // photon paths per pass
  float radius = 0.f;          // initial radius (resolved: > 0)
  float alpha = 0.7f;
  int64_t pass_offset = 0;
  bool stochastic_hash = false;
  bool light_bvh = false;  // the visible points' light sample chosen by the light BVH (--light-sampler bvh)
  bool adaptive = false;   // sppm, ppm, pppm: --photon-sampling adaptive (Hachisuka & Jensen 2011)
  bool hide_emitters = false;  // the visible points' emission at the end of the camera segment left out
  // In a scene with media (volumetric photon mapping, sppm.h, pm.h): volume photons in a second grid, their
  // initial radius (resolved: > 0, photon_media_setup; pm: 0, it takes the k nearest)
  bool media = false;
  bool grid_media = false;  // ppm: a medium is a grid, so the measurement points' weights are drawn every pass
  int32_t outer_medium = -1;  // where photon paths that meet no medium boundary start (outer_medium)
  float volume_radius = 0.f;
  // adaptive: the first sizes of a chain's regions (photons per payload, deposits per chain; 0: four per
  // step of the longest chain); they grow to what the chains need, so the photons do not depend on them
  // (tests start them at 1 to run the growth).
  uint32_t adaptive_payload = 16;
  uint64_t adaptive_deposits = 0;
};
std::unique_ptr<WavefrontRenderer> make_cpu_photon_wavefront(std::shared_ptr<Scene> scene,
                                                             const PhotonWavefrontParams& p, const CpuAccel* accel);

// What the bidirectional wavefront needs beyond the scene (RenderOptions of light / bdpt / bpm / vcm,
// resolved as the CPU driver resolves them: vcm_render.h).
struct VcmWavefrontParams {
  VcmParams base;              // mode, depths, seed, sampler, n_light; pass and radius are set per pass
  uint32_t light_paths = 0;    // light subpaths per pass (exact; base.n_light is its float)
  float radius = 0.f;          // r_1 (resolved: > 0)
  float alpha = 0.75f;         // radius schedule r_i = r_1 i^((alpha - 1) / 2)
  float volume_radius = 0.f;   // bpm, vcm in media: volumetric merging's r_v,1 (0: the surface radius; vcm.h)
};
std::unique_ptr<WavefrontRenderer> make_cpu_vcm_wavefront(std::shared_ptr<Scene> scene, const VcmWavefrontParams& p,
                                                          const CpuAccel* accel);

// What the restir driver needs beyond the scene (RenderOptions of restir, resolved).
struct RestirWavefrontParams {
  PathParams pp;    // max_depth, rr_depth, seed, sampler (jitter on)
  RestirParams rp;
};
std::unique_ptr<WavefrontRenderer> make_cpu_restir_wavefront(std::shared_ptr<Scene> scene,
                                                             const RestirWavefrontParams& p, const CpuAccel* accel);

}  // namespace caustica
