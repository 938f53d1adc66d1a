// The driver of `restir` (integrator/restir.h) over the backend interface (backend/backend.h): run by the CPU
// backend (oneTBB + Embree or the portable BVH; the default and --wavefront) and by the CUDA backend from this
// one source. Each pass:
//   1. per pixel (restir_primary): the camera path to its shading point and on (emission, longer paths), RIS
//      over the light candidates there, temporal reuse of the previous pass's final reservoir at the pixel;
//   2. per pixel (restir_spatial): spatial reuse of the neighbours' stage-1 reservoirs (a finished buffer),
//      one shadow ray, the pixel's sample into the film (render.h's Film layout: r, g, b, weight per pixel and
//      the odd passes apart);
//   3. the pass's shading points and final reservoirs become the next pass's history (buffers swapped).
// Both stages are one kernel each over the pixels ("megakernels": the camera path's bounces run inside the
// stage-1 kernel, unlike the path tracer's queues). Random numbers depend on (seed, pass, pixel, stage) only,
// so the image depends neither on the thread count nor on the backend's schedule.
#pragma once
#include <atomic>
#include <cstdint>
#include <vector>

#include "../backend/backend.h"
#include "restir.h"
#include "wavefront_film.h"
#include "wavefront_render.h"

namespace caustica {

template <class B>
class WavefrontRestir {
 public:
  template <class T>
  using Buffer = typename B::template Buffer<T>;

  WavefrontRestir(const B& backend, const RestirWavefrontParams& p)
      : b_(backend), p_(p),
        film_(backend, uint32_t(backend.scene().camera.width) * uint32_t(backend.scene().camera.height)) {
    const Camera& c = b_.scene().camera;
    W_ = uint32_t(c.width);
    H_ = uint32_t(c.height);
    n_ = W_ * H_;
    vert_.resize(n_);
    prev_vert_.resize(n_);
    temporal_.resize(n_);
    prev_res_.resize(n_);
    final_.resize(n_);
    L_.resize(n_);
    weight_.resize(n_);
    rays_.resize(n_);
    shadow_.resize(n_);
    invalid_.resize(n_);
  }

  // Renders pass `pass`; false when `cancel` was set between the stages (the film and history are then
  // unchanged).
  bool render_pass(uint32_t pass, const std::atomic<bool>* cancel, WavefrontPassStats& stats) {
    const SceneView s = b_.scene();
    const auto tracer = b_.tracer();
    RestirPass p;
    p.pp = p_.pp;
    p.rp = p_.rp;
    p.seed = p_.pp.seed;
    p.pass = pass;
    p.width = W_;
    p.height = H_;
    p.temporal = p_.rp.history > 0.f && have_history_;
    const uint32_t W = W_;
    stats = WavefrontPassStats();
    const RestirVertex* prev_vert = prev_vert_.data();
    const Reservoir* prev_res = prev_res_.data();
    RestirVertex* vert = vert_.data();
    Reservoir* temporal = temporal_.data();
    Reservoir* fin = final_.data();
    RGB* L = L_.data();
    float* weight = weight_.data();
    uint32_t* rays = rays_.data();
    uint32_t* shadow = shadow_.data();
    uint32_t* invalid = invalid_.data();
    b_.parallel_for(n_, CAUSTICA_KERNEL(uint32_t i) {
      rays[i] = 0;
      shadow[i] = 0;
      restir_primary(s, tracer, p, i % W, i / W, prev_vert[i], prev_res[i], vert[i], temporal[i], L[i], weight[i],
                     rays[i], shadow[i]);
    });
    if (cancel && cancel->load(std::memory_order_relaxed)) return false;
    double* sum = film_.sum();
    double* odd = film_.odd();
    const bool odd_pass = (pass & 1u) != 0;
    b_.parallel_for(n_, CAUSTICA_KERNEL(uint32_t i) {
      RGB Li = L[i];
      restir_spatial(s, tracer, p, i % W, i / W, vert, temporal, fin[i], Li, shadow[i]);
      bool ok = isfinite3(Li);
      invalid[i] = ok ? 0u : 1u;
      if (ok) film_add(sum, odd, odd_pass, i, Li, weight[i]);
    });
    std::swap(prev_vert_, vert_);
    std::swap(prev_res_, final_);
    have_history_ = true;
    stats.rays = sum_counts(rays_);
    stats.shadow_rays = sum_counts(shadow_);
    stats.invalid = sum_counts(invalid_);
    return true;
  }

  void film(std::vector<double>& sum, std::vector<double>& odd) const { film_.to_host(sum, odd); }

 private:
  uint64_t sum_counts(const Buffer<uint32_t>& counts) const {
    std::vector<uint32_t> h(n_);
    b_.to_host(counts, h.data(), n_);
    uint64_t t = 0;
    for (uint32_t x : h) t += x;
    return t;
  }

  const B& b_;
  RestirWavefrontParams p_;
  uint32_t W_ = 0, H_ = 0, n_ = 0;
  bool have_history_ = false;
  Buffer<RestirVertex> vert_, prev_vert_;
  Buffer<Reservoir> temporal_, prev_res_, final_;
  Buffer<RGB> L_;
  Buffer<float> weight_;
  Buffer<uint32_t> rays_, shadow_, invalid_;
  WavefrontFilm<B> film_;
};

}  // namespace caustica
