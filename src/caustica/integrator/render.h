// The CPU driver: renders progressive passes of an integrator into a film,
// in parallel over pixel tiles (oneTBB), under a sample or time budget, and
// can be cancelled between tiles with every finished sample kept.
#pragma once
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "../base/sampler.h"
#include "../photon/adaptive.h"
#include "../scene/scene.h"

namespace caustica {

struct RenderOptions {
  std::string integrator = "path";
  int64_t spp = 0;        // samples per pixel; 0 with a time budget means "until the time is spent"
  double time = 0.0;      // seconds; 0 = no time budget
  uint64_t seed = 0;
  int threads = 0;        // 0 = all hardware threads
  int max_depth = -2;     // segments (Mitsuba's count); -1 = unlimited; -2 = the scene's default
  int rr_depth = 5;
  SamplerType sampler = SamplerType::kSobol;
  // "auto" (the small-scene test for scenes of at most 128 triangles, else Embree: CpuAccel), "embree",
  // "small" (an InputError for a scene it does not take) or "bvh" (the portable BVH).
  std::string accel = "auto";
  // Where and how `path` runs: "cpu", or "cuda" / "cuda:N" (the CUDA backend: the wavefront path tracer,
  // integrator/wavefront_path.h, on the portable BVH). `wavefront` runs the same driver on the CPU.
  std::string device = "cpu";
  bool wavefront = false;
  bool compaction = true;           // wavefront: stream compaction of finished paths
  bool sort_materials = false;      // wavefront: sort the queue by material before shading
  bool cache_first_bounce = false;  // wavefront: reuse the first pass's camera-ray hits (needs jitter off)
  bool jitter = true;               // path: false = samples through pixel centres (no anti-aliasing)
  // path on the CPU: trace eight paths in lockstep where the lane-parallel driver covers the scene
  // (integrator/path_lanes.h; the image is bit-identical either way); false = one path at a time.
  bool lanes = true;
  // Every integrator: emitters seen directly from the camera add nothing (Mitsuba's hide_emitters; PathParams).
  bool hide_emitters = false;
  // path: an output variable of the first surface instead of radiance (path.h, Aov): "" (radiance), "depth",
  // "position", "normal", "geo_normal", "uv" or "albedo".
  std::string aov;
  // Photon mapping (ppm, sppm, pppm)
  int64_t photons = 0;       // photon paths per pass; 0 = one per pixel
  float radius = 0.f;        // initial gather radius; 0 = automatic (twice the median pixel footprint)
  // pppm in scenes with participating media: the volume photons' initial radius; 0 = automatic
  // (automatic_volume_radius in photon_render.h)
  float volume_radius = 0.f;
  float alpha = 0.7f;        // radius reduction (Hachisuka et al. 2008; Knaus & Zwicker 2011)
  int64_t pass_offset = 0;   // pppm: render passes [pass_offset, pass_offset + spp)
  bool stochastic_hash = false;  // keep one photon per hash cell (Hachisuka & Jensen 2010)
  // ppm, sppm, pppm on the CPU: "uniform" (independent photon paths) or "adaptive" (Markov chains on the
  // photon paths' visibility, Hachisuka & Jensen 2011: photon/adaptive.h).
  std::string photon_sampling = "uniform";
  int k = 50;                // pm: photons per k-nearest density estimate
  // restir (ReSTIR DI, integrator/restir.h): light candidates per pixel and pass, spatial neighbours (0: no
  // spatial reuse), their radius in pixels, the temporal history cap in multiples of the candidates (0: no
  // temporal reuse); the defaults are Bitterli et al. 2020's.
  int restir_candidates = 32;
  int restir_neighbors = 5;
  float restir_radius = 30.f;
  float restir_history = 20.f;
  // light_sampler_applies' integrators: how next-event estimation from camera paths (and restir's candidates)
  // chooses a light: "power" (in proportion to power: an alias table) or "bvh" (by the light BVH's importance
  // from the shading point, light/light_bvh.h; light_sampler_applies).
  std::string light_sampler = "power";
  // light, bdpt, bpm, vcm: keep one image per strategy (Veach 1997 Fig. 10.3): connections (s, t) of paths
  // up to kStrategyMaxLength segments, merges per camera vertex (VcmIntegrator::strategy_images).
  bool strategy_images = false;
  // Stop on quality (checked at the end of passes; whichever of spp, time and a
  // target comes first ends the render). The error is relMSE with epsilon 0.01:
  // mean over pixels and channels of (x - r)^2 / (r^2 + 0.01).
  double target_error = 0.0;    // > 0: stop when relMSE(image, reference) <= target_error
  std::vector<float> reference; // H*W*3 linear RGB, for target_error
  double target_noise = 0.0;    // > 0 (path): stop when the estimated relMSE from noise <= target_noise
};

// relMSE of an image against a reference (both H*W*3), epsilon 0.01 (shared/scenes/cornell-box.md).
double relmse(const std::vector<float>& img, const std::vector<float>& ref);


struct RenderStats {
  int64_t passes = 0;        // completed passes (samples per pixel)
  int64_t target_passes = 0; // 0 when the budget is time
  uint64_t samples = 0;      // camera paths traced
  uint64_t rays = 0;         // camera + bounce rays
  uint64_t shadow_rays = 0;
  uint64_t invalid_samples = 0;  // NaN/inf radiance, dropped
  uint64_t photons = 0;          // photon paths traced (photon integrators)
  float radius = 0.f;            // initial gather radius (photon integrators)
  float volume_radius = 0.f;     // pppm and sppm in media: the volume photons' initial radius (0: no media)
  AdaptiveSummary adaptive;      // --photon-sampling adaptive
  double seconds = 0.0;
  bool done = false;
  bool cancelled = false;
  double error = -1.0;           // the last relMSE checked against the reference (-1: none)
  double noise = -1.0;           // the last noise estimate (-1: none)
  bool target_reached = false;   // stopped because a target was met
  int lanes = 0;                 // path on the CPU: paths traced in lockstep (8), or 0 (one at a time)
  // sppm/ppm/pppm/pm on the wavefront (--wavefront, --device cuda): seconds spent per stage over all passes, and
  // the photons stored (the hash grid's input). light/bdpt/bpm/vcm/upg on the wavefront: seconds_light,
  // seconds_grid, seconds_camera, seconds_accumulate, and the light vertices stored in stored_photons.
  double seconds_visible = 0.0, seconds_photons = 0.0, seconds_grid = 0.0, seconds_gather = 0.0;
  double seconds_light = 0.0, seconds_camera = 0.0, seconds_accumulate = 0.0;
  uint64_t stored_photons = 0;
};

enum class Aov : uint32_t;  // integrator/path.h
// The output variable named `name` (RenderOptions::aov; Aov::kNone for an unknown name), and the names.
Aov aov_kind(const std::string& name);
std::string aov_names();

// Names of the integrators this build offers (the registry).
const std::vector<std::string>& integrator_names();

// The restir options' ranges, shared by RenderOptions' check and the JSON scene loader: for `name`
// ("candidates", "neighbors", "radius", "history") and value v, an empty string when v is allowed, else
// what is expected ("an integer in [1, 1024]", ...).
std::string restir_option_expected(const std::string& name, double v);

// Whether `integrator` takes light_sampler "bvh": those whose camera paths choose lights for next-event
// estimation from a shading point (path, restir, the photon mappers' visible points: pm, ppm, sppm, pppm, and
// the bidirectional integrators with next-event estimation: bdpt, vcm, upg); the list, comma-separated.
bool light_sampler_applies(const std::string& integrator);
std::string light_sampler_integrators();

// Accumulated radiance per pixel, with the odd passes also kept apart so that
// the two half images (even passes, odd passes) give a per-pixel variance
// estimate: for N samples split evenly, E[(A - B)^2] = 4 Var(mean of N)
// (the "two half buffers" of LuxCore's halt threshold and Cycles' adaptive sampling).
class Film {
 public:
  Film(int w, int h) : width(w), height(h), sum(size_t(w) * h * 4, 0.0), odd(size_t(w) * h * 4, 0.0) {}
  void add(uint32_t pixel, RGB L, float w, bool odd_pass) {
    double* p = &sum[size_t(pixel) * 4];
    p[0] += double(L.x) * w;
    p[1] += double(L.y) * w;
    p[2] += double(L.z) * w;
    p[3] += w;
    if (odd_pass) {
      double* q = &odd[size_t(pixel) * 4];
      q[0] += double(L.x) * w;
      q[1] += double(L.y) * w;
      q[2] += double(L.z) * w;
      q[3] += w;
    }
  }
  std::vector<float> image() const;  // H*W*3, weighted mean per pixel
  // Estimated relMSE of image() due to noise: mean over pixels and channels of
  // ((A - B) / 2)^2 / (I^2 + 0.01), A and B the even- and odd-pass means, I the
  // full mean (valid after an even number of passes); -1 before two passes.
  double noise_relmse() const;
  int width, height;
  std::vector<double> sum;  // r, g, b, weight per pixel
  std::vector<double> odd;  // the same over odd passes only
};

class PhotonIntegrator;
class VcmIntegrator;
class UpgIntegrator;
class WavefrontRenderer;
struct PathParams;
struct WavefrontPassStats;

// Whether the options run the wavefront path tracer (on the CPU with `wavefront`, or on CUDA).
bool uses_wavefront(const RenderOptions& o);
// The CUDA device index of "cuda" (0) or "cuda:N"; -1 for "cpu".
int cuda_device_index(const std::string& device);

class RenderJob {
 public:
  RenderJob(std::shared_ptr<Scene> scene, RenderOptions opt);
  ~RenderJob();
  // Validates options; throws InputError naming the option and allowed values.
  static void validate(const RenderOptions& opt);

  void run();     // renders on the calling thread until the budget is spent or cancelled
  void start();   // renders on a background thread
  bool wait(double timeout_seconds);  // true when finished
  void cancel() { cancel_.store(true); }
  RenderStats stats() const;
  // The image so far (a copy taken between passes); with at_snapshot, also the counters that match it
  // (stats() read afterwards may already count tiles of the next pass).
  std::vector<float> image(RenderStats* at_snapshot = nullptr) const;
  // With RenderOptions::strategy_images: (name, H*W*3 image) per strategy, means over the passes done,
  // each already MIS-weighted (they sum to image() over paths up to the length limit).
  std::vector<std::pair<std::string, std::vector<float>>> strategy_images() const;
  // "cpu", "cpu (wavefront, embree)", "cuda:0 (NVIDIA H100 ...)": where the passes run.
  std::string device_name() const;
  // What answers the ray queries: "small" or "embree" (CpuAccel::name()), or "bvh" (the portable BVH: --accel
  // bvh, and the GPU).
  std::string accel_name() const;
  int width() const { return film_.width; }
  int height() const { return film_.height; }

 private:
  template <typename Accel>
  void render_pass(const Accel& accel, int64_t pass);
  PathParams path_params() const;
  void make_integrator();  // the constructor's: photon_, vcm_, upg_ or wavefront_ for opt_
  Film wavefront_film() const;
  std::shared_ptr<Scene> scene_;
  RenderOptions opt_;
  Film film_;
  mutable std::mutex mutex_;  // guards film_ snapshots against an in-flight pass
  mutable std::atomic<int> snapshot_waiting_{0};  // image() calls waiting for mutex_ (the render loop yields to them)
  std::atomic<bool> cancel_{false};
  std::atomic<bool> finished_{false};
  std::atomic<int64_t> passes_{0};
  std::atomic<uint64_t> samples_{0}, rays_{0}, shadow_rays_{0}, invalid_{0};
  std::atomic<double> seconds_{0.0};
  std::atomic<double> error_value_{-1.0}, noise_value_{-1.0};
  std::atomic<bool> target_reached_{false};
  const CpuAccel& cpu_accel() const;  // the scene's CPU accelerator that opt_.accel names
  bool lanes_ = false;  // render_pass runs the lane-parallel driver (path_lanes.h)
  bool target_met(int64_t passes_done);
  std::thread thread_;
  std::unique_ptr<PhotonIntegrator> photon_;
  AdaptiveSummary adaptive_;           // --photon-sampling adaptive: the chains' counters after the last pass
  mutable std::mutex adaptive_mutex_;  // guards adaptive_
  std::unique_ptr<VcmIntegrator> vcm_;  // light, bdpt, bpm, vcm
  std::unique_ptr<UpgIntegrator> upg_;
  std::unique_ptr<WavefrontRenderer> wavefront_;
  float volume_radius_ = 0.f;  // pppm and sppm in media on the wavefront: the volume photons' initial radius;
                               // bpm and vcm in media: volumetric merging's (vcm.h)
  std::atomic<uint64_t> photons_{0};
  std::unique_ptr<WavefrontPassStats> stage_totals_;  // wavefront renders: sums over passes
  mutable std::mutex stage_mutex_;                     // guards stage_totals_ (held briefly)
  std::string error_;
};

}  // namespace caustica
