// CPU driver of upg (see upg_render.h and upg.h).
#include "upg_render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "../backend/cpu/cpu_accel.h"
#include "../photon/hash_grid.h"
#include "photon_render.h"
#include "upg.h"
#include "vcm_render.h"

namespace caustica {

UpgIntegrator::UpgIntegrator(std::shared_ptr<Scene> scene, const RenderOptions& opt)
    : scene_(std::move(scene)), opt_(opt) {
  const SceneView& v = scene_->view();
  int md = opt.max_depth == -2 ? scene_->desc().max_depth : opt.max_depth;
  max_depth_ = md < 0 ? 0xffffffffu : uint32_t(md);
  W_ = v.camera.width;
  H_ = v.camera.height;
  sum_.assign(size_t(W_) * H_ * 3, 0.0);
  // The gathering radius is fixed (no shrinking: the estimator is unbiased for any r).
  // Default: one median pixel footprint of first hits, as vcm (docs/integrators.md: on the
  // SmallVCM scenes twice that cost 1.6-2.9x more time for the same variance).
  r_ = vcm_initial_radius(*scene_, opt);
  if (scene_has_media(v)) outer_medium_ = vcm_outer_medium(*scene_, scene_->cpu_accel(opt.accel), opt);
}

bool UpgIntegrator::render_pass(int64_t pass, const std::atomic<bool>& cancel) {
  const SceneView& s = scene_->view();
  const CpuAccel& accel = scene_->cpu_accel(opt_.accel);
  const uint32_t n = uint32_t(W_) * uint32_t(H_);
  VcmParams p = vcm_pass_params(opt_, VcmMode::kUpg, max_depth_, pass, n);
  const uint32_t nl = vcm_light_paths(opt_, n);  // exact (p.n_light is a float)
  vcm_set_radius(p, r_);
  p.outer_medium = outer_medium_;

  // 1. Light subpaths in fixed chunks (trace_light_subpaths in vcm_render.cpp).
  LightSubpaths lp;
  if (!trace_light_subpaths(s, p, accel, nl, /*keep_vertices=*/true, cancel, lp)) return false;
  const std::vector<VcmLightVertex>& verts = lp.verts;
  const std::vector<uint32_t>& start = lp.start;
  const std::vector<std::vector<VcmSplat>>& csplats = lp.splats;
  std::atomic<uint64_t> rays{lp.rays}, trials{0}, capped{0};

  // 2. Hash grid of light vertices. The grid stores quantized positions: queries use the
  // radius plus a slack above the quantization error, and the exact test |z - y| < r is
  // made on the full-precision vertex positions.
  PhotonHashGrid grid;
  PhotonGridView gv;
  const float slack = upg_query_slack(s.bounds, r_);
  if (!verts.empty()) {
    std::vector<Photon> ph(verts.size());
    for (size_t k = 0; k < verts.size(); ++k) {
      ph[k].p = verts[k].sh.p;
      ph[k].wi = verts[k].wi;
      ph[k].power = verts[k].beta;
    }
    grid.build(ph, s.bounds, 2.f * (r_ + slack), false, 0, true);
    gv = grid.view();
  }

  // 3. Camera subpaths.
  std::vector<RGB> pass_L(n, RGB(0.f));
  tbb::parallel_for(tbb::blocked_range<int>(0, H_, 1), [&](const tbb::blocked_range<int>& r) {
    uint64_t nrays = 0, ntrials = 0, ncapped = 0;
    for (int y = r.begin(); y < r.end(); ++y) {
      if (cancel.load(std::memory_order_relaxed)) break;
      for (int x = 0; x < W_; ++x) {
        VcmPathState st, prev;
        bool have_prev = false;  // prev: the previous eye vertex, a non-delta surface vertex (upg_track_prev)
        vcm_camera_start(s, p, uint32_t(x), uint32_t(y), st);
        const uint32_t pix = st.pixel;
        while (st.active) {
          Hit hit;
          accel.intersect(st.ray, hit);
          ++nrays;
          vcm_camera_hit(s, p, st, hit);
          // Gather at this eye hit z_t (whatever its material; a surface, upg.h) from z_{t-1} = prev, in the
          // grid's order (a fixed order: the grid and its query are deterministic; the wavefront driver sums
          // the same way).
          if (upg_gathers_at(st, hit, have_prev, prev)) {
            UpgGatherCounts c = upg_gather_all(s, p, prev, st, gv, r_ + slack, verts.data(), pix, accel);
            nrays += c.rays;
            ntrials += c.trials;
            ncapped += c.capped;
          }
          if (!st.active) break;
          VcmShadow sr;
          vcm_camera_nee(s, p, st, sr);
          if (sr.active) {
            ++nrays;
            vcm_shadow(st, sr, vcm_visibility(s, accel, sr.ray, sr.medium));
          }
          if (st.vertex_valid)
            for (uint32_t k = start[pix % nl]; k < start[pix % nl + 1]; ++k) {
              vcm_camera_connect(s, p, st, verts[k], sr);
              if (sr.active) {
                ++nrays;
                vcm_shadow(st, sr, vcm_visibility(s, accel, sr.ray, sr.medium));
              }
            }
          upg_track_prev(st, have_prev, prev);
          vcm_camera_continue(s, p, st);
        }
        if (isfinite3(st.L)) pass_L[pix] = st.L;
      }
    }
    rays += nrays + ntrials;
    trials += ntrials;
    capped += ncapped;
  });
  if (cancel.load()) return false;

  // 4. Accumulate: camera estimates, then the splats in chunk order.
  accumulate_pass(s, p, pass_L, csplats, sum_);
  traced_ += nl;
  rays_ += rays.load();
  trials_ += trials.load();
  capped_ += capped.load();
  return true;
}

std::vector<float> UpgIntegrator::image(int64_t passes) const { return mean_image(sum_, passes); }

}  // namespace caustica
