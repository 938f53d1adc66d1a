// The path tracer (integrator/path.h) as a wavefront: each stage a parallel_for over a queue of paths
// (Laine, Karras & Aila 2013, "Megakernels Considered Harmful: Wavefront Path Tracing on GPUs", Sec. 4),
// written once over the backend interface (backend/backend.h) and run by the CPU backend (oneTBB +
// Embree) and the CUDA backend (kernels + CUB + the portable BVH).
//
// One pass = one sample per pixel; path slot i belongs to pixel i. Per depth:
//   intersect  closest hit of every queued path's ray (or, at depth 0 with first-bounce caching, the hits
//              of the first pass: camera rays are then the same every pass)
//   sort       optional: the queue sorted by the hit's material (misses last), so that neighbouring
//              threads run the same BSDF code (Laine et al. 2013 Sec. 4.2 keep one queue per material;
//              sorting by key does the same with one queue)
//   shade      path_shade: emission with MIS, NEE (a shadow ray), BSDF sampling, Russian roulette
//   shadow     any-hit query of each shadow ray (in scenes with media, closest hits through null surfaces
//              and the media's transmittance: path_shadow_transmittance); path_shadow adds the NEE contribution
//   compact    optional stream compaction: the paths still active, in queue order, by a prefix sum of
//              their flags and a scatter (Harris, Sengupta & Owens 2007, "Parallel Prefix Sum (Scan) with
//              CUDA", GPU Gems 3 Ch. 39.3.1); without it every stage runs over all slots and idles on the
//              finished ones
// and after the last depth, accumulate adds each pixel's sample to the film (the same weighted sums and
// odd-pass half buffer as the CPU Film, render.h). Every path owns its random stream and its slot, so the
// order of the queue changes nothing: with Embree the image is bit-identical to the CPU path tracer's, with
// and without compaction, sorting and caching (tests/cpp/test_wavefront.cpp).
#pragma once
#include <atomic>
#include <cstdint>
#include <vector>

#include "../backend/backend.h"
#include "path.h"
#include "wavefront_film.h"
#include "wavefront_render.h"

namespace caustica {

template <class B>
class WavefrontPath {
 public:
  template <class T>
  using Buffer = typename B::template Buffer<T>;

  WavefrontPath(const B& backend, const PathParams& pp, const WavefrontOptions& opt, uint32_t num_materials)
      : b_(backend), pp_(pp), opt_(opt), num_materials_(num_materials),
        film_(backend, uint32_t(backend.scene().camera.width) * uint32_t(backend.scene().camera.height)) {
    const Camera& c = b_.scene().camera;
    n_ = uint32_t(c.width) * uint32_t(c.height);
    states_.resize(n_);
    hits_.resize(n_);
    shadow_.resize(n_);
    if (scene_wants_equiangular(backend.scene())) equiangular_.resize(n_);
    queue_.resize(n_);
    queue2_.resize(n_);
    flags_.resize(n_);
    scan_.resize(n_);
    if (opt_.sort_materials) keys_.resize(n_);
    if (opt_.cache_first_bounce) cache_.resize(n_);
  }

  uint32_t pixels() const { return n_; }

  // Renders sample `sample_index` of every pixel into the film. Returns false when `cancel` was set
  // midway: the film is then unchanged.
  bool render_pass(uint32_t sample_index, const std::atomic<bool>* cancel, WavefrontPassStats& stats) {
    const SceneView s = b_.scene();
    const PathParams pp = pp_;
    const auto tracer = b_.tracer();
    const uint32_t n = n_, W = uint32_t(s.camera.width);
    PathState* states = states_.data();
    Hit* hits = hits_.data();
    ShadowRay* shadow = shadow_.data();
    ShadowRay* eq = equiangular_.size() ? equiangular_.data() : nullptr;  // scenes with media and point lights
    uint32_t* flags = flags_.data();
    uint32_t* scan = scan_.data();
    stats = WavefrontPassStats();

    {
      uint32_t* queue = queue_.data();
      b_.parallel_for(n, CAUSTICA_KERNEL(uint32_t i) {
        path_start(s, pp, i % W, i / W, sample_index, states[i]);
        queue[i] = i;
      });
    }
    uint32_t len = n, active_paths = n;  // path_start leaves every path active
    for (uint32_t depth = 0; len > 0; ++depth) {
      if (cancel && cancel->load(std::memory_order_relaxed)) return false;
      uint32_t* queue = queue_.data();
      // Closest hits. The first depth's queue is every slot in order, so the cache is indexed by slot.
      const bool cached = depth == 0 && opt_.cache_first_bounce && cache_valid_;
      if (cached) {
        const Hit* cache = cache_.data();
        b_.parallel_for(n, CAUSTICA_KERNEL(uint32_t i) { hits[i] = cache[i]; });
      } else {
        b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
          uint32_t i = queue[k];
          if (states[i].active) tracer.intersect(states[i].ray, hits[i]);
        });
        if (depth == 0 && opt_.cache_first_bounce) {
          Hit* cache = cache_.data();
          b_.parallel_for(n, CAUSTICA_KERNEL(uint32_t i) { cache[i] = hits[i]; });
          cache_valid_ = true;
        }
      }
      // Rays traced: the paths active after the previous depth (every path at depth 0), known without a scan.
      if (!cached) stats.rays += active_paths;  // cached camera rays were not traced this pass
      if (opt_.sort_materials) {
        // Keys: the hit's material, then misses, then finished paths (never shaded).
        const uint32_t nm = num_materials_;
        uint32_t* keys = keys_.data();
        b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
          uint32_t i = queue[k];
          keys[k] = !states[i].active ? nm + 1 : hits[i].valid() ? s.prim_material[hits[i].prim] : nm;
        });
        int bits = 1;
        while ((uint64_t(1) << bits) <= uint64_t(nm) + 1) ++bits;
        b_.sort_pairs(keys, queue, len, bits, sort_k_, sort_v_);
      }
      b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
        uint32_t i = queue[k];
        if (states[i].active) {
          path_shade(s, pp, states[i], hits[i], shadow[i], eq ? eq + i : nullptr);
        } else {
          shadow[i].active = false;
          if (eq) eq[i].active = false;
        }
      });
      b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
        uint32_t i = queue[k];
        flags[k] = (shadow[i].active ? 1u : 0u) + (eq && eq[i].active ? 1u : 0u);
        if (shadow[i].active) path_shadow(states[i], shadow[i], path_shadow_transmittance(s, tracer, shadow[i]));
        if (eq && eq[i].active) path_shadow(states[i], eq[i], path_shadow_transmittance(s, tracer, eq[i]));
      });
      stats.shadow_rays += b_.exclusive_scan(flags, scan, len);
      b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) { flags[k] = states[queue[k]].active ? 1u : 0u; });
      const uint32_t active = b_.exclusive_scan(flags, scan, len);
      active_paths = active;
      if (opt_.compaction) {
        uint32_t* out = queue2_.data();
        b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
          if (flags[k]) out[scan[k]] = queue[k];
        });
        std::swap(queue_, queue2_);
        len = active;
      } else if (active == 0) {
        len = 0;
      }
    }
    if (cancel && cancel->load(std::memory_order_relaxed)) return false;
    // Accumulate: slot i is pixel i.
    double* sum = film_.sum();
    double* odd = film_.odd();
    const bool odd_pass = (sample_index & 1u) != 0;
    b_.parallel_for(n, CAUSTICA_KERNEL(uint32_t i) {
      const PathState& st = states[i];
      bool ok = isfinite3(st.L);
      flags[i] = ok ? 0u : 1u;
      if (ok) film_add(sum, odd, odd_pass, i, st.L, st.weight);
    });
    stats.invalid = b_.exclusive_scan(flags, scan, n);
    return true;
  }

  // The film's sums (4 doubles per pixel: r, g, b, weight) over all passes and over odd passes.
  void film(std::vector<double>& sum, std::vector<double>& odd) const { film_.to_host(sum, odd); }

 private:
  const B& b_;
  PathParams pp_;
  WavefrontOptions opt_;
  uint32_t num_materials_;
  uint32_t n_ = 0;
  Buffer<PathState> states_;
  Buffer<Hit> hits_, cache_;
  Buffer<ShadowRay> shadow_, equiangular_;
  Buffer<uint32_t> queue_, queue2_, flags_, scan_, keys_, sort_k_, sort_v_;
  WavefrontFilm<B> film_;
  bool cache_valid_ = false;
};

}  // namespace caustica
