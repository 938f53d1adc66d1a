// CPU driver of light / bdpt / bpm / vcm (see vcm_render.h and vcm.h).
#include "vcm_render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "../backend/cpu/cpu_accel.h"
#include "../base/error.h"
#include "../photon/hash_grid.h"
#include "photon_render.h"
#include "vcm.h"

namespace caustica {

bool is_vcm_integrator(const std::string& n) { return n == "light" || n == "bdpt" || n == "bpm" || n == "vcm"; }

VcmMode vcm_mode(const std::string& n) {
  return n == "light" ? VcmMode::kLight
         : n == "bdpt" ? VcmMode::kBpt
         : n == "bpm"  ? VcmMode::kBpm
         : n == "upg"  ? VcmMode::kUpg
                       : VcmMode::kVcm;
}

VcmIntegrator::VcmIntegrator(std::shared_ptr<Scene> scene, const RenderOptions& opt)
    : scene_(std::move(scene)), opt_(opt) {
  const SceneView& v = scene_->view();
  mode_ = int(vcm_mode(opt.integrator));
  int md = opt.max_depth == -2 ? scene_->desc().max_depth : opt.max_depth;
  max_depth_ = md < 0 ? 0xffffffffu : uint32_t(md);
  W_ = v.camera.width;
  H_ = v.camera.height;
  sum_.assign(size_t(W_) * H_ * 3, 0.0);
  // Initial radius, unless given: one median pixel footprint (first-hit
  // distance x pixel angle) of camera rays, half the photon integrators' default.
  // Every eye vertex merges here (not only one visible point per pixel), so the
  // merge cost grows with r^2; at twice the footprint vcm lost to SmallVCM on
  // smallvcm-point, at one footprint it won (bench/RESULTS.md, bidirectional).
  r0_ = vcm_initial_radius(*scene_, opt);
  if (scene_has_media(v)) outer_medium_ = vcm_outer_medium(*scene_, scene_->cpu_accel(opt.accel), opt);
  if ((VcmMode(mode_) == VcmMode::kBpm || VcmMode(mode_) == VcmMode::kVcm) && scene_has_media(v))
    rv0_ = vcm_initial_volume_radius(*scene_, scene_->cpu_accel(opt.accel), opt, VcmMode(mode_), max_depth_, r0_,
                                     outer_medium_);
  if (opt.strategy_images) {
    for (uint32_t k = 1; k <= kStrategyMaxLength; ++k)
      for (uint32_t s = 0; s <= k; ++s)
        strat_names_.push_back("k" + std::to_string(k) + "_s" + std::to_string(s) + "_t" + std::to_string(k + 1 - s));
    for (uint32_t t = 2; t <= kStrategyMaxLength; ++t) strat_names_.push_back("merge_t" + std::to_string(t));
    strat_sum_.assign(strat_names_.size(), std::vector<float>(sum_.size(), 0.f));
    strat_pass_ = strat_sum_;
  }
}

// Connections of paths of k = s + t - 1 segments, k = 1 .. kStrategyMaxLength, in order of k then s.
int VcmIntegrator::connection_slot(uint32_t s, uint32_t t) const {
  uint32_t k = s + t - 1;
  if (strat_sum_.empty() || t < 1 || k < 1 || k > kStrategyMaxLength) return -1;
  return int((k - 1) * (k + 2) / 2 + s);  // sum_{j < k} (j + 1) = (k - 1)(k + 2)/2
}
// Merges at the camera vertex t (after t - 1 segments; t >= 2), after the connections.
int VcmIntegrator::merge_slot(uint32_t t) const {
  if (strat_sum_.empty() || t < 2 || t > kStrategyMaxLength) return -1;
  return int(kStrategyMaxLength * (kStrategyMaxLength + 3) / 2 + (t - 2));
}

std::vector<std::pair<std::string, std::vector<float>>> VcmIntegrator::strategy_images(int64_t passes) const {
  std::vector<std::pair<std::string, std::vector<float>>> out;
  for (size_t i = 0; i < strat_names_.size(); ++i) {
    std::vector<float> img(strat_sum_[i].size(), 0.f);
    if (passes > 0)
      for (size_t j = 0; j < img.size(); ++j) img[j] = strat_sum_[i][j] / float(passes);
    out.emplace_back(strat_names_[i], std::move(img));
  }
  return out;
}

float VcmIntegrator::radius(int64_t pass) const { return vcm_radius(r0_, opt_.alpha, pass); }

float vcm_radius(float r0, float alpha, int64_t pass) {
  return float(double(r0) * std::pow(double(pass + 1), 0.5 * (double(alpha) - 1.0)));
}

float vcm_volume_radius(float rv0, float alpha, int64_t pass) {
  if (!(rv0 > 0.f)) return 0.f;
  return float(double(rv0) * std::pow(double(pass + 1), (double(alpha) - 1.0) / 3.0));
}

int32_t vcm_outer_medium(const Scene& scene, const CpuAccel& accel, const RenderOptions& opt) {
  return outer_medium(scene, accel, opt.integrator, "light subpaths");
}

float vcm_initial_radius(const Scene& scene, const RenderOptions& opt) {
  return opt.radius > 0.f ? opt.radius : 0.5f * automatic_radius(scene);
}

float vcm_initial_volume_radius(const Scene& scene, const CpuAccel& accel, const RenderOptions& opt, VcmMode mode,
                                uint32_t max_depth, float r0, int32_t outer_medium) {
  if (opt.volume_radius > 0.f) return opt.volume_radius;
  const SceneView& v = scene.view();
  if (!scene_has_media(v)) return 0.f;
  const int W = v.camera.width, H = v.camera.height;
  if (mode == VcmMode::kBpm) {
    // bpm merges alone: a ball that holds about kVolumeRadiusK light vertices of a pass where they are typical
    // (pppm's automatic volume radius over n_light photon paths).
    const float rv = automatic_volume_radius(scene, accel, opt.seed, vcm_light_paths(opt, uint32_t(W) * uint32_t(H)),
                                             max_depth == 0xffffffffu ? max_depth : max_depth - 1, outer_medium);
    if (rv > 0.f) return rv;
  }
  // Camera subpaths of 32 x 32 pixels (vcm's own stages, in a pass no render uses, one after another: the same
  // result for any thread count) through delta surfaces and null boundaries up to their first vertex; where that
  // is a scattering event in a medium, the distance travelled to it times the pixel's angle.
  VcmParams p = vcm_pass_params(opt, VcmMode::kVcm, 0xffffffffu, 0xfffffffe, uint32_t(W) * uint32_t(H));
  vcm_set_radius(p, r0);
  const float pixel_angle = 2.f * v.camera.tan_half_y / float(H);
  std::vector<float> fp;
  for (int y = 0; y < H; y += std::max(1, H / 32))
    for (int x = 0; x < W; x += std::max(1, W / 32)) {
      VcmPathState st;
      vcm_camera_start(v, p, uint32_t(x), uint32_t(y), st);
      float travelled = 0.f;
      for (int k = 0; k < 64 && st.active; ++k) {
        Hit hit;
        accel.intersect(st.ray, hit);
        const Vec3f o = st.ray.o;
        vcm_camera_hit(v, p, st, hit);
        if (st.crossing) {
          travelled += length(st.ray.o - o);
          continue;
        }
        if (!st.active && !st.vertex_valid) break;
        travelled += length(st.sh.p - o);
        if (st.vertex_valid) {
          if (st.in_medium) fp.push_back(v.camera.orthographic ? pixel_angle : travelled * pixel_angle);
          break;
        }
        vcm_camera_continue(v, p, st);  // a delta surface: on along its sampled direction
      }
    }
  if (fp.empty()) return 0.f;
  std::nth_element(fp.begin(), fp.begin() + fp.size() / 2, fp.end());
  return fp[fp.size() / 2];
}

// Stage 1 of vcm and upg: n light subpaths traced in fixed chunks of 1024
// (random streams from (seed, pass, path index), so the result does not depend
// on the thread count), their vertices concatenated in path order and their
// camera splats kept per chunk, to be added to the film in chunk order.
bool trace_light_subpaths(const SceneView& s, const VcmParams& p, const CpuAccel& accel, uint32_t n,
                          bool keep_vertices, const std::atomic<bool>& cancel, LightSubpaths& out) {
  const uint32_t chunk = 1024;
  const uint32_t nchunks = (n + chunk - 1) / chunk;
  std::vector<std::vector<VcmLightVertex>> cverts(nchunks);
  std::vector<std::vector<uint32_t>> ccount(nchunks);  // vertices per light path
  std::vector<std::vector<VcmSplat>>& csplats = out.splats;
  csplats.assign(nchunks, {});
  std::atomic<uint64_t> rays{0};
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, nchunks, 1), [&](const tbb::blocked_range<uint32_t>& r) {
    uint64_t nrays = 0;
    for (uint32_t c = r.begin(); c < r.end(); ++c) {
      if (cancel.load(std::memory_order_relaxed)) break;
      uint32_t end = std::min(n, (c + 1) * chunk);
      ccount[c].reserve(end - c * chunk);
      for (uint32_t i = c * chunk; i < end; ++i) {
        VcmPathState st;
        vcm_light_start(s, p, i, st);
        vcm_light_locate(s, p, st, [&](const Ray& ray, Hit& h) { accel.intersect(ray, h); });
        uint32_t count = 0;
        while (st.active) {
          Hit hit;
          accel.intersect(st.ray, hit);
          ++nrays;
          VcmLightVertex v;
          if (vcm_light_hit(s, p, st, hit, v) && keep_vertices) {
            cverts[c].push_back(v);
            ++count;
          }
          if (!st.active) break;
          VcmSplat sp;
          vcm_light_to_camera(s, p, st, sp);
          if (sp.active) {
            ++nrays;
            const RGB tr = vcm_visibility(s, accel, sp.ray, sp.medium);
            if (!is_black(tr)) {
              sp.C *= tr;
              csplats[c].push_back(sp);
            }
          }
          vcm_light_continue(s, p, st);
        }
        ccount[c].push_back(count);
      }
    }
    rays += nrays;
  });
  if (cancel.load()) return false;
  out.rays = rays.load();
  std::vector<VcmLightVertex>& verts = out.verts;
  std::vector<uint32_t>& start = out.start;
  verts.clear();
  start.assign(size_t(n) + 1, 0);
  {
    size_t total = 0;
    for (auto& cv : cverts) total += cv.size();
    verts.reserve(total);
    uint32_t i = 0;
    for (uint32_t c = 0; c < nchunks; ++c) {
      verts.insert(verts.end(), cverts[c].begin(), cverts[c].end());
      for (uint32_t k : ccount[c]) {
        start[i + 1] = start[i] + k;
        ++i;
      }
      std::vector<VcmLightVertex>().swap(cverts[c]);
    }
  }
  return true;
}

bool VcmIntegrator::render_pass(int64_t pass, const std::atomic<bool>& cancel) {
  const SceneView& s = scene_->view();
  const CpuAccel& accel = scene_->cpu_accel(opt_.accel);
  const uint32_t n = uint32_t(W_) * uint32_t(H_);
  VcmParams p = vcm_pass_params(opt_, VcmMode(mode_), max_depth_, pass, n);
  p.outer_medium = outer_medium_;
  const uint32_t nl = vcm_light_paths(opt_, n);  // exact (p.n_light is a float)
  vcm_set_radius(p, radius(pass), vcm_volume_radius(rv0_, opt_.alpha, pass));

  // 1. Light subpaths in fixed chunks (trace_light_subpaths, shared with upg).
  const bool keep_vertices = p.use_vc() || p.use_vm();
  LightSubpaths lp;
  if (!trace_light_subpaths(s, p, accel, nl, keep_vertices, cancel, lp)) return false;
  const std::vector<VcmLightVertex>& verts = lp.verts;
  const std::vector<uint32_t>& start = lp.start;
  const std::vector<std::vector<VcmSplat>>& csplats = lp.splats;
  std::atomic<uint64_t> rays{lp.rays};

  // 2. The hash grids of light vertices for merging: those on surfaces (cells of 2r) and those in media (cells
  // of 2 r_v; empty in scenes without media).
  PhotonHashGrid grid, grid_v;
  PhotonGridView gv, gvv;
  std::vector<VcmMergeVertex> merge_verts, merge_verts_v;  // what merges read of verts, in each grid's order
  if (p.merges() && !verts.empty()) {
    // idx: the vertices' indices (nullptr: all of them, in scenes without media).
    auto build = [&](const uint32_t* idx, size_t count, float r, PhotonHashGrid& g, PhotonGridView& view,
                     std::vector<VcmMergeVertex>& records) {
      if (count == 0) return;
      std::vector<Photon> ph(count);
      for (size_t k = 0; k < count; ++k) {
        const VcmLightVertex& v = verts[idx ? idx[k] : k];
        ph[k].p = v.sh.p;
        ph[k].wi = v.wi;
        ph[k].power = v.beta;
      }
      g.build(ph, s.bounds, 2.f * r, false, 0, true);
      view = g.view();
      // The merges read each found vertex's record; in path order (108-byte VcmLightVertex) those reads
      // missed the cache at random and were the hottest instruction of the merge query (perf, 512 x 512
      // smallvcm-mirror-ball). A compact copy in the grid's order keeps the records of a cell run
      // together; the query then reports grid positions.
      const std::vector<uint32_t>& ids = g.ids();
      records.resize(ids.size());
      tbb::parallel_for(tbb::blocked_range<size_t>(0, ids.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t j = r.begin(); j < r.end(); ++j) records[j] = vcm_merge_vertex(verts[idx ? idx[ids[j]] : ids[j]]);
      });
      view.ids = nullptr;
    };
    if (!scene_has_media(s)) {
      build(nullptr, verts.size(), p.radius, grid, gv, merge_verts);
    } else {
      std::vector<uint32_t> which[2];  // the indices of the surface and of the medium vertices, in path order
      for (uint32_t k = 0; k < uint32_t(verts.size()); ++k) which[verts[k].in_medium()].push_back(k);
      build(which[0].data(), which[0].size(), p.radius, grid, gv, merge_verts);
      build(which[1].data(), which[1].size(), p.radius_v, grid_v, gvv, merge_verts_v);
    }
  }

  // 3. Camera subpaths, one per pixel, in parallel over rows (each pixel owned by one task).
  std::vector<RGB> pass_L(n, RGB(0.f));
  const bool rec = !strat_pass_.empty();
  for (auto& b : strat_pass_) std::fill(b.begin(), b.end(), 0.f);
  auto record = [&](int slot, uint32_t pix, RGB c) {  // a strategy's weighted contribution to a pixel
    if (slot < 0 || !isfinite3(c)) return;
    float* q = &strat_pass_[size_t(slot)][3 * size_t(pix)];
    q[0] += c.x, q[1] += c.y, q[2] += c.z;
  };
  tbb::parallel_for(tbb::blocked_range<int>(0, H_, 1), [&](const tbb::blocked_range<int>& r) {
    uint64_t nrays = 0;
    for (int y = r.begin(); y < r.end(); ++y) {
      if (cancel.load(std::memory_order_relaxed)) break;
      for (int x = 0; x < W_; ++x) {
        VcmPathState st;
        vcm_camera_start(s, p, uint32_t(x), uint32_t(y), st);
        const uint32_t pix = st.pixel;
        while (st.active) {
          Hit hit;
          accel.intersect(st.ray, hit);
          ++nrays;
          RGB before = st.L;
          vcm_camera_hit(s, p, st, hit);
          if (rec) record(connection_slot(0, st.length + 1), pix, st.L - before);
          if (!st.active) break;
          VcmShadow sr;
          vcm_camera_nee(s, p, st, sr);
          if (sr.active) {
            ++nrays;
            const RGB tr = vcm_visibility(s, accel, sr.ray, sr.medium);
            vcm_shadow(st, sr, tr);
            if (rec && !is_black(tr)) record(connection_slot(1, st.length + 1), pix, sr.contrib * tr);
          }
          if (st.vertex_valid && p.use_vc())
            for (uint32_t k = start[pix % nl]; k < start[pix % nl + 1]; ++k) {
              vcm_camera_connect(s, p, st, verts[k], sr);
              if (sr.active) {
                ++nrays;
                const RGB tr = vcm_visibility(s, accel, sr.ray, sr.medium);
                vcm_shadow(st, sr, tr);
                if (rec && !is_black(tr))
                  record(connection_slot(verts[k].length + 1, st.length + 1), pix, sr.contrib * tr);
              }
            }
          if (st.vertex_valid && p.merges()) {
            before = st.L;
            vcm_camera_merge(s, p, st, gv, merge_verts.data(), gvv, merge_verts_v.data());
            if (rec) record(merge_slot(st.length + 1), pix, st.L - before);
          }
          vcm_camera_continue(s, p, st);
        }
        if (isfinite3(st.L)) pass_L[pix] = st.L;
      }
    }
    rays += nrays;
  });
  if (cancel.load()) return false;

  // 4. Accumulate: camera estimates, then the splats in chunk order.
  if (rec)
    accumulate_pass(s, p, pass_L, csplats, sum_, [&](uint32_t pix, RGB v, const VcmSplat& sp) {
      record(connection_slot(sp.length + 1, 1), pix, v);
    });
  else
    accumulate_pass(s, p, pass_L, csplats, sum_);
  for (size_t i = 0; i < strat_pass_.size(); ++i)
    for (size_t j = 0; j < strat_pass_[i].size(); ++j) strat_sum_[i][j] += strat_pass_[i][j];
  traced_ += nl;
  rays_ += rays.load();
  return true;
}

VcmParams vcm_pass_params(const RenderOptions& opt, VcmMode mode, uint32_t max_depth, int64_t pass, uint32_t pixels) {
  VcmParams p;
  p.mode = mode;
  p.light_bvh = opt.light_sampler == "bvh";
  p.hide_emitters = opt.hide_emitters;
  p.max_depth = max_depth;
  p.rr_depth = uint32_t(opt.rr_depth);
  p.seed = opt.seed;
  p.pass = uint32_t(pass);
  p.sampler = opt.sampler;
  p.n_light = float(vcm_light_paths(opt, pixels));
  return p;
}

uint32_t vcm_light_paths(const RenderOptions& opt, uint32_t pixels) {
  return opt.photons > 0 ? uint32_t(opt.photons) : pixels;
}

void accumulate_pass(const SceneView& s, const VcmParams& p, const std::vector<RGB>& pass_L,
                     const std::vector<std::vector<VcmSplat>>& splats, std::vector<double>& sum,
                     const std::function<void(uint32_t, RGB, const VcmSplat&)>& on_splat) {
  for (size_t i = 0; i < pass_L.size(); ++i)
    for (int c = 0; c < 3; ++c) sum[3 * i + c] += double(pass_L[i][c]);
  for (const std::vector<VcmSplat>& chunk : splats)
    for (const VcmSplat& sp : chunk)
      vcm_splat_pixels(s, p, sp, [&](uint32_t pix, RGB v) {
        if (!isfinite3(v)) return;
        for (int k = 0; k < 3; ++k) sum[3 * size_t(pix) + k] += double(v[k]);
        if (on_splat) on_splat(pix, v, sp);
      });
}

std::vector<float> mean_image(const std::vector<double>& sum, int64_t passes) {
  std::vector<float> img(sum.size(), 0.f);
  if (passes <= 0) return img;
  for (size_t i = 0; i < sum.size(); ++i) img[i] = float(sum[i] / double(passes));
  return img;
}

std::vector<float> VcmIntegrator::image(int64_t passes) const { return mean_image(sum_, passes); }

}  // namespace caustica
