// CPU driver of restir (see restir_render.h and restir.h).
#include "restir_render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "../backend/cpu/cpu_accel.h"
#include "restir.h"

namespace caustica {

namespace {

constexpr uint64_t kStageTemporal = 1, kStageSpatial = 2;

// Bitterli et al. 2020's neighbour test: normals within 25 degrees, depths within 10%. It looks at the
// shading points only (never at the samples), so skipping a neighbour keeps the estimate unbiased.
bool similar(const RestirShading& a, const RestirShading& b) {
  return a.valid && b.valid && dot(a.frame.n, b.frame.n) >= 0.906307787f &&
         std::fabs(a.depth - b.depth) <= 0.1f * a.depth;
}

RestirParams restir_params(const RenderOptions& o) {
  RestirParams p;
  p.candidates = uint32_t(o.restir_candidates);
  p.neighbors = uint32_t(o.restir_neighbors);
  p.radius = o.restir_radius;
  p.history = o.restir_history;
  return p;
}

}  // namespace

RestirIntegrator::RestirIntegrator(std::shared_ptr<Scene> scene, const RenderOptions& opt)
    : scene_(std::move(scene)), opt_(opt),
      film_(scene_->view().camera.width, scene_->view().camera.height) {
  int md = opt.max_depth == -2 ? scene_->desc().max_depth : opt.max_depth;
  max_depth_ = md < 0 ? 0xffffffffu : uint32_t(md);
  W_ = film_.width;
  H_ = film_.height;
  const size_t n = size_t(W_) * H_;
  vert_.resize(n);
  prev_vert_.resize(n);
  temporal_.resize(n);
  prev_res_.resize(n);
  final_.resize(n);
  path_L_.resize(n);
  weight_.resize(n);
}

RestirIntegrator::~RestirIntegrator() = default;

bool RestirIntegrator::render_pass(int64_t pass, const std::atomic<bool>& cancel) {
  if (opt_.accel == "bvh") return pass_with(BVHAccel{&scene_->view()}, pass, cancel);
  return pass_with(scene_->cpu_accel(opt_.accel), pass, cancel);
}

template <typename Accel>
bool RestirIntegrator::pass_with(const Accel& accel, int64_t pass, const std::atomic<bool>& cancel) {
  const SceneView& s = scene_->view();
  const RestirParams rp = restir_params(opt_);
  PathParams pp;
  pp.max_depth = max_depth_;
  pp.rr_depth = uint32_t(opt_.rr_depth);
  pp.seed = opt_.seed;
  pp.sampler = opt_.sampler;
  const uint64_t pass_key = uint64_t(pass);
  std::atomic<uint64_t> rays{0}, shadow{0};
  const bool temporal = rp.history > 0.f && pass > 0;

  // 1. Camera paths, shading points, initial candidates, temporal reuse.
  tbb::parallel_for(tbb::blocked_range<int>(0, H_, 1), [&](const tbb::blocked_range<int>& r) {
    uint64_t nrays = 0, nshadow = 0;
    for (int py = r.begin(); py < r.end(); ++py) {
      if (cancel.load(std::memory_order_relaxed)) break;
      for (int px = 0; px < W_; ++px) {
        PathState st;
        path_start(s, pp, uint32_t(px), uint32_t(py), uint32_t(pass), st);
        const uint32_t pix = st.pixel;
        RestirVertex v;
        float travelled = 0.f;
        while (st.active) {
          Hit hit;
          accel.intersect(st.ray, hit);
          ++nrays;
          if (!v.valid && hit.valid() && st.depth + 1 < pp.max_depth) {
            SurfaceHit sh = make_surface_hit(s, st.ray, hit);
            SurfaceHit shm = sh;
            if (!material_is_delta(surface_material(s, shm))) {
              v.sh = sh;
              v.wo = -st.ray.d;
              v.beta = st.beta * segment_transmittance(s, st.ray.d, hit.t, sh);
              v.depth = travelled + hit.t;
              v.valid = true;
              // Emission here and the BSDF sample onwards as the path tracer; its light sample is not traced
              // (ReSTIR estimates the direct light here), and the emitters the BSDF sample reaches through a
              // non-delta lobe are left to ReSTIR too.
              ShadowRay unused;
              path_shade(s, pp, st, hit, unused);
              st.nee_only = st.active && !st.prev_delta;
              continue;
            }
          }
          if (hit.valid()) travelled += hit.t;
          path_vertex(s, pp, accel, st, hit, nshadow);
        }
        path_L_[pix] = st.L;
        weight_[pix] = st.weight;
        vert_[pix] = v;

        PCG32 rng(kStageTemporal, hash3(opt_.seed, pass_key, pix));
        RestirShading sq = restir_shading(s, v);
        Reservoir init = restir_initial(s, sq, rp.candidates, rng);
        if (temporal && sq.valid) {
          RestirShading sp = restir_shading(s, prev_vert_[pix]);
          if (similar(sq, sp)) {
            const RestirShading* vs[2] = {&sq, &sp};
            Reservoir in[2] = {init, prev_res_[pix]};
            float c[2] = {init.c, std::min(in[1].c, rp.history * float(rp.candidates))};
            init = restir_combine(s, vs, in, c, 2, rng);
          }
        }
        temporal_[pix] = init;
      }
    }
    rays += nrays;
    shadow += nshadow;
  });
  if (cancel.load()) return false;

  // 2. Spatial reuse of the stage-1 reservoirs, shading.
  std::atomic<uint64_t> invalid{0};
  tbb::parallel_for(tbb::blocked_range<int>(0, H_, 1), [&](const tbb::blocked_range<int>& r) {
    uint64_t nshadow = 0, ninvalid = 0;
    constexpr int kMaxInputs = 1 + 32;
    RestirShading shade[kMaxInputs];
    const RestirShading* vs[kMaxInputs];
    Reservoir in[kMaxInputs];
    float c[kMaxInputs];
    for (int py = r.begin(); py < r.end(); ++py) {
      if (cancel.load(std::memory_order_relaxed)) break;
      for (int px = 0; px < W_; ++px) {
        const uint32_t pix = uint32_t(py) * uint32_t(W_) + uint32_t(px);
        PCG32 rng(kStageSpatial, hash3(opt_.seed, pass_key, pix));
        shade[0] = restir_shading(s, vert_[pix]);
        Reservoir res = temporal_[pix];
        if (shade[0].valid && rp.neighbors > 0) {
          int n = 1;
          vs[0] = &shade[0];
          in[0] = res;
          c[0] = res.c;
          for (uint32_t k = 0; k < rp.neighbors; ++k) {
            // A neighbour uniformly in the disk of radius R around the pixel.
            Vec2f d = square_to_concentric_disk(Vec2f(rng.next_float(), rng.next_float())) * rp.radius;
            int nx = px + int(std::lround(d.x)), ny = py + int(std::lround(d.y));
            if (nx < 0 || ny < 0 || nx >= W_ || ny >= H_ || (nx == px && ny == py)) continue;
            const uint32_t q = uint32_t(ny) * uint32_t(W_) + uint32_t(nx);
            shade[n] = restir_shading(s, vert_[q]);
            if (!similar(shade[0], shade[n])) continue;
            vs[n] = &shade[n];
            in[n] = temporal_[q];
            c[n] = temporal_[q].c;
            ++n;
          }
          if (n > 1) res = restir_combine(s, vs, in, c, n, rng);
        }
        final_[pix] = res;
        RGB L = path_L_[pix];
        if (res.has_sample()) {
          Vec3f wi;
          float dist = kInf;
          RGB g = restir_contribution(s, shade[0], res.y, wi, dist);
          if (!is_black(g)) {
            Ray ray = restir_shadow_ray(s, shade[0], res.y, wi);
            ++nshadow;
            if (!accel.occluded(ray)) L += g * res.W;
          }
        }
        if (!isfinite3(L)) {
          ++ninvalid;
          continue;
        }
        film_.add(pix, L, weight_[pix], (pass & 1) != 0);
      }
    }
    shadow += nshadow;
    invalid += ninvalid;
  });
  if (cancel.load()) return false;

  // 3. History for the next pass.
  std::swap(prev_vert_, vert_);
  std::swap(prev_res_, final_);
  rays_ += rays.load();
  shadow_rays_ += shadow.load();
  invalid_ += invalid.load();
  return true;
}

}  // namespace caustica
