// The CPU driver of the bidirectional integrators (integrator/vcm.h):
// light, bdpt, bpm, vcm. Each pass traces one light subpath per pixel (in fixed
// chunks, in parallel; vertices and light-tracing splats concatenated in chunk
// order), builds the hash grid of light vertices for merging, then one camera
// subpath per pixel that connects to the light subpath of the same index
// (SmallVCM's pairing) and merges with all light vertices. Splats are added to
// the image in chunk order, so images do not depend on the thread count.
#pragma once
#include <atomic>
#include <functional>
#include <memory>
#include <vector>

#include "render.h"
#include "vcm.h"

namespace caustica {

bool is_vcm_integrator(const std::string& name);
VcmMode vcm_mode(const std::string& name);  // of a bidirectional integrator's name, or upg's

class CpuAccel;

// Light subpaths of one pass (stage 1 of vcm and upg).
struct LightSubpaths {
  std::vector<VcmLightVertex> verts;          // every path's stored vertices, in path order
  std::vector<uint32_t> start;                // path i's vertices: [start[i], start[i + 1])
  std::vector<std::vector<VcmSplat>> splats;  // unoccluded camera splats, per chunk of 1024 paths
  uint64_t rays = 0;
};
// False if cancelled midway.
bool trace_light_subpaths(const SceneView& s, const VcmParams& p, const CpuAccel& accel, uint32_t n,
                          bool keep_vertices, const std::atomic<bool>& cancel, LightSubpaths& out);
// The parameters of pass `pass` (0-based) of vcm and upg, radius not yet set. Light subpaths per pass:
// RenderOptions::photons, default one per pixel (SmallVCM's pairing); camera path i connects to light
// subpath i mod n_light (n_VC = 1), merges, gathers and light tracing use all of them (N_VM = n_light).
VcmParams vcm_pass_params(const RenderOptions& opt, VcmMode mode, uint32_t max_depth, int64_t pass, uint32_t pixels);
uint32_t vcm_light_paths(const RenderOptions& opt, uint32_t pixels);  // light subpaths per pass
// The merge radius of pass `pass` (0-based): r_1 (pass + 1)^((alpha - 1) / 2) (Georgiev et al. 2012, Sec. 5).
float vcm_radius(float r0, float alpha, int64_t pass);
// Volumetric merging's radius of pass `pass` (bpm, vcm in media; vcm.h): rv0 (pass + 1)^((alpha - 1) / 3), the
// 3D kernel's schedule (its variance grows as r^-3), from rv0 = RenderOptions::volume_radius; 0 when that is 0
// (then the surface radius of the pass).
float vcm_volume_radius(float rv0, float alpha, int64_t pass);
// r_1: RenderOptions::radius, else half the photon integrators' automatic radius (see the constructor).
float vcm_initial_radius(const Scene& scene, const RenderOptions& opt);
// bpm and vcm in media, volumetric merging's r_v,1: RenderOptions::volume_radius, else for vcm one pixel
// footprint where camera paths first scatter in a medium (the median over 32 x 32 pixels of the distance
// travelled to that event, through delta surfaces and null boundaries, times the pixel's angle: vcm's surface
// radius is a footprint at the first hit; MIS gives the merges of a small ball only the paths connections
// sample badly), for bpm, which merges alone, pppm's automatic volume radius over a pass's light subpaths (a
// ball of about kVolumeRadiusK light vertices; the footprint where the pass stores no volume photons); 0 (the
// surface radius) where no camera path scatters in a medium. max_depth: the render's (segments); outer_medium:
// where light subpaths that meet no boundary start (vcm_outer_medium).
float vcm_initial_volume_radius(const Scene& scene, const CpuAccel& accel, const RenderOptions& opt, VcmMode mode,
                                uint32_t max_depth, float r0, int32_t outer_medium);
// The medium of the region outside every medium boundary for light subpaths (VcmParams::outer_medium): the
// camera's when the camera is in that region, else vacuum; InputError when the camera's medium is not the
// one the shapes around it enclose. (Callers ask only in scenes with media: it needs the CPU accelerator.)
int32_t vcm_outer_medium(const Scene& scene, const CpuAccel& accel, const RenderOptions& opt);
// Last stage of vcm and upg: adds a finished pass to `sum` (3 per pixel): the camera estimates, then the
// light-tracing splats in chunk order (so images do not depend on the thread count); on_splat, if given,
// sees each splat's finite value at each pixel it reaches.
void accumulate_pass(const SceneView& s, const VcmParams& p, const std::vector<RGB>& pass_L,
                     const std::vector<std::vector<VcmSplat>>& splats, std::vector<double>& sum,
                     const std::function<void(uint32_t pixel, RGB value, const VcmSplat& splat)>& on_splat = {});
// The image of `passes` accumulated passes: sum / passes as floats (zeros before the first pass).
std::vector<float> mean_image(const std::vector<double>& sum, int64_t passes);

class VcmIntegrator {
 public:
  VcmIntegrator(std::shared_ptr<Scene> scene, const RenderOptions& opt);
  // Renders pass `pass` (0-based); false if cancelled midway (the pass is discarded).
  bool render_pass(int64_t pass, const std::atomic<bool>& cancel);
  std::vector<float> image(int64_t passes_done) const;
  float initial_radius() const { return r0_; }
  float initial_volume_radius() const { return rv0_; }  // 0: the surface radius (vcm_initial_volume_radius)
  uint64_t photons_traced() const { return traced_; }
  uint64_t rays() const { return rays_; }
  // Merge radius of pass i (0-based): r_1 (i + 1)^((alpha - 1) / 2) (Georgiev et al. 2012, Sec. 5).
  float radius(int64_t pass) const;
  // Per-strategy images (RenderOptions::strategy_images), means over passes_done: "k{k}_s{s}_t{t}" for the
  // connection strategies of paths of k <= kStrategyMaxLength segments (s light vertices, t camera vertices,
  // s + t = k + 1: s = 0 is a camera path reaching a light, s = 1 next-event estimation, t = 1 light tracing),
  // "merge_t{t}" for merges at the camera vertex after t - 1 segments (all path lengths). Weighted
  // contributions: they add up to the image over paths of at most kStrategyMaxLength segments.
  static constexpr uint32_t kStrategyMaxLength = 7;
  std::vector<std::pair<std::string, std::vector<float>>> strategy_images(int64_t passes_done) const;

 private:
  std::shared_ptr<Scene> scene_;
  RenderOptions opt_;
  int mode_;
  uint32_t max_depth_;
  float r0_ = 0.f;
  float rv0_ = 0.f;  // bpm, vcm in media: volumetric merging's r_v,1 (vcm_initial_volume_radius)
  int32_t outer_medium_ = -1;  // VcmParams::outer_medium (vcm_outer_medium)
  int W_, H_;
  uint64_t traced_ = 0, rays_ = 0;
  std::vector<double> sum_;  // 3 per pixel: camera-path estimates (weighted by h/p) plus splats, summed over passes
  // Strategy images: slot -1 when not kept; sums over completed passes and the pass in flight.
  int connection_slot(uint32_t s, uint32_t t) const;
  int merge_slot(uint32_t t) const;
  std::vector<std::string> strat_names_;
  std::vector<std::vector<float>> strat_sum_, strat_pass_;
};

}  // namespace caustica
