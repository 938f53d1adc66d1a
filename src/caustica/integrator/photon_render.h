// The photon-mapping integrators on the CPU (docs/integrators.md):
//   ppm  - Hachisuka, Ogaki & Jensen 2008, "Progressive Photon Mapping":
//          measurement points traced once (through specular bounces to the first
//          non-specular hit), then photon passes; per point N, R, tau updated with
//          alpha (Sec. 4.1-4.3, Eqs. 6-11); L = tau / (pi R^2 N_emitted) (Eq. 12).
//   sppm - Hachisuka & Jensen 2009, "Stochastic Progressive Photon Mapping": new
//          visible points every pass, the same statistics shared per pixel
//          (Sec. 4, Eqs. 5-8); direct light by NEE at the visible points.
//   pppm - Knaus & Zwicker 2011, "Progressive Photon Mapping: A Probabilistic
//          Approach": every pass an independent image with the global radius of
//          Eq. 15, r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1); images averaged.
//          Passes are memoryless, so passes [i0, i0 + k) can be rendered anywhere
//          and averaged later (RenderOptions::pass_offset).
//          In scenes with participating media (pppm and sppm; the wavefront's too): volumetric photon
//          mapping (Jensen & Christensen 1998) with volume photons in their own hash grid, gathered at volume
//          visible points with a ball: pppm's global volume radius, r_{i+1}^3 = r_i^3 (i + alpha) / (i + 1),
//          or sppm's per-pixel statistics of volume points, R^3 reduced like the disc's area (sppm.h).
//   --photon-sampling adaptive (ppm, sppm, pppm) - Hachisuka & Jensen 2011, "Robust Adaptive Photon Tracing
//          using Photon Path Visibility": each pass's photon paths drawn by Markov chains whose target is
//          the visibility of the path to the pass's visible points (photon/adaptive.h).
//   pm   - Jensen 1996, "Global Illumination using Photon Maps" (and Jensen 2001
//          Ch. 7-9): a global and a caustic photon map built once (kd-trees),
//          then per pass one camera sample per pixel: emission and specular
//          reflection by recursion, direct light by NEE, caustics by a k-nearest
//          density estimate of the caustic map with the cone filter (Jensen 2001
//          Eq. 7.7, normalisation 1 - 2/(3k)), indirect diffuse by final gathering:
//          a BSDF-sampled ray whose hit is estimated from the global map (stage functions in pm.h;
//          the wavefront driver, wavefront_photon.h, runs the same on the portable kd-tree).
#pragma once
#include <memory>
#include <vector>

#include "../backend/cpu/cpu_accel.h"
#include "../photon/adaptive.h"
#include "../photon/kdtree.h"
#include "../photon/photon.h"
#include "render.h"
#include "sppm.h"

namespace caustica {


// The default gather radius of the photon, bidirectional-merging and gathering
// integrators: twice the median pixel footprint (first-hit distance x pixel
// angle) of camera rays through a grid of at most 32 x 32 pixels.
float automatic_radius(const Scene& scene);

// The default initial radius of the volume photons (pppm and sppm in media): the median, over up to 256
// volume photons spread through a pass of `photons` photon paths (seed, pass index kVolumeRadiusPass), of the
// distance to their kVolumeRadiusK-th nearest volume photon, so that a ball of that radius holds about
// that many photons of a pass where they are typical; 0 when the pass stores no volume photons.
constexpr int kVolumeRadiusK = 32;
float automatic_volume_radius(const Scene& scene, const CpuAccel& accel, uint64_t seed, uint64_t photons,
                              uint32_t max_depth, int32_t outside = -1);

// The medium of the region outside every medium boundary, where paths from lights start when their first ray
// meets no boundary (locate_medium's `outside`): the camera's medium when the camera's forward ray meets no
// boundary (the camera is in that region), else vacuum. An InputError naming `integrator` and `paths` (what
// could not reach the camera) when the camera's medium is not the one the shapes around it enclose.
int32_t outer_medium(const Scene& scene, const CpuAccel& accel, const std::string& integrator,
                     const std::string& paths);

// pm, ppm, pppm or sppm in a scene with media, on every driver: the medium photon paths start in outside every
// boundary (outer_medium, into *outside) and the volume photons' initial radius (opt.volume_radius, else
// automatic_volume_radius over `photons` paths of photon_depth segments, else r0; pm, whose estimates take
// the k nearest, has none: 0).
float photon_media_setup(const Scene& scene, const CpuAccel& accel, const RenderOptions& opt, uint64_t photons,
                         uint32_t photon_depth, float r0, int32_t* outside);

class PhotonIntegrator {
 public:
  PhotonIntegrator(std::shared_ptr<Scene> scene, const RenderOptions& opt);
  // Renders pass `pass` (0-based, counted from pass_offset); returns false if cancelled midway
  // (the pass is then discarded and the statistics are unchanged).
  bool render_pass(int64_t pass, const std::atomic<bool>& cancel);
  std::vector<float> image(int64_t passes_done) const;
  float initial_radius() const { return r0_; }
  // ppm, pppm or sppm in a scene with media: the volume photons' initial radius (0 otherwise).
  float initial_volume_radius() const { return rv0_; }
  uint64_t photons_per_pass() const { return photons_per_pass_; }
  uint64_t photons_traced() const { return traced_; }
  // --photon-sampling adaptive: the chains' counters summed over the passes done, and the mutation size
  // the next pass uses.
  AdaptiveSummary adaptive_summary() const;
  const ChainCounts& chain_counts() const { return chains_.totals; }
  // Traces one pass of photons in deterministic order (also used by tests).
  // `outside`: trace_photon_path's.
  static std::vector<Photon> trace_photons(const SceneView& v, const CpuAccel& accel, uint64_t seed, uint32_t pass,
                                           uint64_t count, uint32_t max_depth, bool keep_direct,
                                           const std::atomic<bool>* cancel = nullptr, int32_t outside = -1);

 private:
  enum class Kind { kPPM, kSPPM, kPPPM, kPM } kind_;
  void render_pm_pass(int64_t abs_pass);
  // pm's maps (pm.h): the global and caustic maps, and in scenes with media the volume photons, all and
  // those after a bounce.
  PhotonKdTree global_, caustic_, volume_, volume_indirect_;
  uint64_t global_paths_ = 0;
  uint64_t traced_ = 0;
  void trace_visible_points(int64_t abs_pass);
  // The photons of one pass drawn by the visibility chains (photon/adaptive.h; rv: the largest volume radius
  // in media, else 0), their powers scaled by
  // n_vis / S, the chains' counts in pass_counts_ (committed to chains_ when the pass completes); empty if
  // cancelled.
  std::vector<Photon> trace_photons_adaptive(int64_t abs_pass, uint32_t photon_depth, float rmax, float rv,
                                             const std::atomic<bool>& cancel);
  bool adaptive_ = false;
  AdaptiveChainState chains_;
  ChainCounts pass_counts_;
  std::shared_ptr<Scene> scene_;
  RenderOptions opt_;
  uint32_t max_depth_;
  uint64_t photons_per_pass_;
  float r0_;
  bool media_ = false;  // in a scene with media: volume photons (and but for pm volume visible points)
  int32_t outer_medium_ = -1;  // where photon paths that meet no medium boundary start (outer_medium)
  float rv0_ = 0.f;     // ppm, pppm, sppm: their initial radius (RenderOptions::volume_radius, else automatic_volume_radius)
  std::vector<double> Nv_, tauv_;  // ppm, sppm in media: each pixel's statistics of its volume visible points
  std::vector<float> Rv_;          // (sppm_update with dims 3), beside N_, tau_, R_ for its surface ones
  bool remeasure_ = false;  // ppm in a scene with grid media: the measurement points' weights drawn every pass
  int W_, H_;
  int K_ = 1;  // visible points per pixel: 1, or up to kPpmPointsPerPixel for ppm's split specular chains
  // K_ per pixel (pixel i's at i * K_ + k); ppm in media then one per-pass volume visible point per pixel
  // (pixel i's at W_ H_ K_ + i; invalid when its camera ray reached a surface).
  std::vector<VisiblePoint> vp_;
  // Where a volume visible point's per-pixel statistics start: volume point i is pixel i - volume_base()'s
  // (ppm: after its measurement points; pppm and sppm: 0, a pixel's one visible point).
  size_t volume_base() const { return kind_ == Kind::kPPM ? size_t(W_) * H_ * K_ : 0; }
  std::vector<double> direct_;    // 3 per pixel: sum over passes of emitted + NEE direct radiance
  std::vector<double> N_, tau_;   // ppm/sppm: photon count and flux per visible point (tau: 3 each)
  std::vector<float> R_;          // ppm/sppm: radius per visible point
  std::vector<double> indirect_;  // pppm: sum over passes of the per-pass photon estimates (3 per pixel)
};

bool is_photon_integrator(const std::string& name);

// How the photon integrators turn their per-pixel statistics into an image (direct light is averaged over
// the passes in every case): kProgressive (ppm, sppm) adds tau / (pi R^2 N_emitted) over K points per
// pixel (Hachisuka et al. 2008 Eq. 12); kPerPass (pppm) adds the mean of the per-pass estimates (Knaus &
// Zwicker 2011 Eq. 4); kNone (pm) has its photon estimates in `direct` already.
enum class PhotonEstimate { kNone, kProgressive, kPerPass };
// kProgressive in media (sppm) also adds tau_v / (4/3 pi R_v^3 N_emitted) per pixel when tau_v is given.
std::vector<float> photon_image(size_t pixels, int K, int64_t passes, uint64_t photons_per_pass, PhotonEstimate kind,
                                const std::vector<double>& direct, const std::vector<double>& tau,
                                const std::vector<float>& R, const std::vector<double>& indirect,
                                const std::vector<double>* tau_v = nullptr, const std::vector<float>* R_v = nullptr);

}  // namespace caustica
