// Stochastic progressive photon mapping (Hachisuka & Jensen 2009), progressive photon mapping (Hachisuka,
// Ogaki & Jensen 2008) and probabilistic PPM (Knaus & Zwicker 2011) as wavefronts over the backend interface
// (backend/backend.h), the way Hachisuka & Jensen 2010 ("Parallel Progressive Photon Mapping on GPUs",
// SIGGRAPH Asia sketch) run PPM on a GPU. One pass:
//   visible points  one thread per pixel: the camera ray through specular bounces to its visible point,
//                   emission and NEE on the way (sppm.h: trace_camera). ppm keeps only the direct light of
//                   this path: its kPpmPointsPerPixel measurement points per pixel are traced once, in the
//                   first pass (sppm.h: trace_measurement_points), and gather photons in every pass
//   photons         photon paths one segment per stage over a queue of paths (photon_start, then per
//                   depth: intersect, photon_bounce, append the stored photons by a prefix sum of their
//                   flags, compact the queue). Photons land in (depth, path) order: deterministic, no
//                   atomics. With --photon-sampling adaptive (Hachisuka & Jensen 2011): the CPU driver's
//                   Markov chains instead, one thread per chain (trace_photons_adaptive)
//   hash grid       hash_grid.h's construction on the backend: bounds by a reduction, each photon's slot
//                   from its decoded position, a radix sort of (slot, index), cell starts by one writer
//                   per slot boundary; or, with stochastic hashing, one photon per grid cell (a radix sort
//                   of (cell, index), group starts by a prefix sum, the kept photon chosen by hash(seed,
//                   cell) and its power scaled by the cell's count), then the grid over those
//   gather          one thread per visible point: sppm_gather, then sppm_update (sppm, Hachisuka & Jensen
//                   2009 Eqs. 5-8; ppm, Hachisuka et al. 2008 Eqs. 6-11, per measurement point) or pppm_add (pppm, Knaus & Zwicker 2011 Eqs. 3 and 15)
// The stage functions are the CPU photon integrator's (photon_render.cpp); only the order of photons in
// the grid's slots differs (photon_render.cpp appends them path by path), so the sums of a visible point
// are added in another order: images agree with the CPU integrator's to rounding (tests/cpp/
// test_wavefront.cpp), except with stochastic hashing, where the photon kept in a cell is drawn among them
// in another order (same distribution).
// ppm, pppm and sppm in scenes with participating media (volumetric photon mapping, sppm.h and
// photon/trace.h): photon paths start in their light's medium (locate_medium), the stored photons are split
// by a prefix sum into surface photons and volume photons, each in a grid of its own, and volume visible
// points gather from the second with the volume radius (pppm's global one, or sppm's and ppm's per-pixel
// statistics of volume points), as photon_render.cpp does. ppm's volume visible points are the pass's
// camera rays that scatter (one per pixel, after the measurement points); with grid media its measurement
// points are traced again every pass for a new estimate of their transmittance (trace_measurement_points).
// Jensen's photon mapping (pm, Jensen 1996) runs here too, without visible points or grid: its first pass
// traces the photons with the same stages (direct photons kept), builds the global and caustic maps (and in
// media the two volume maps of Jensen & Christensen 1998) on the host as portable kd-trees
// (photon/knn_tree.h) and copies them to the backend; every pass then runs pm.h's pm_radiance per pixel
// (render_pm_pass).
#pragma once
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "../backend/backend.h"
#include "../backend/backend_algorithms.h"
#include "../base/error.h"
#include "../photon/trace.h"
#include "../photon/knn_tree.h"
#include "adaptive_photons.h"
#include "path.h"
#include "pm.h"
#include "sppm.h"
#include "wavefront_render.h"

namespace caustica {

struct BoundsUnion {
  CHD Bounds3 operator()(Bounds3 a, const Bounds3& b) const {
    a.extend(b);
    return a;
  }
};
struct FloatMax {
  CHD float operator()(float a, float b) const { return a > b ? a : b; }
};

// A tracer's closest-hit query as the function locate_medium takes.
template <class T>
struct TracerIntersect {
  T tracer;
  CHD void operator()(const Ray& r, Hit& h) const { tracer.intersect(r, h); }
};

// The sorted hash grid of hash_grid.h built by a backend; view() is what kernels query.
template <class B>
class BackendPhotonGrid {
 public:
  template <class T>
  using Buffer = typename B::template Buffer<T>;

  // Builds over photons[0, n), cell side cell_size, with the scene's bounds extended by the photons'.
  void build(const B& b, const Photon* photons, uint32_t n, const Bounds3& scene_bounds, float cell_size,
             bool stochastic, uint64_t seed) {
    if (pb_.size() < n) pb_.resize(n);
    Bounds3* pb = pb_.data();
    b.parallel_for(n, CAUSTICA_KERNEL(uint32_t i) {
      Bounds3 x;
      x.extend(photons[i].p);
      pb[i] = x;
    });
    Bounds3 bounds = b.reduce(pb, n, scene_bounds, BoundsUnion());
    shape_ = PhotonGridView();
    shape_.quant = make_photon_quantizer(bounds);
    shape_.cell_size = cell_size;
    shape_.inv_cell_size = 1.f / cell_size;
    const PhotonGridView g = shape_;
    if (stochastic) {
      select_one_per_cell(b, photons, n, seed);
      photons = kept_.data();
      n = kept_count_;
    }
    // Table: the smallest power of two >= 2n (at most half the slots occupied).
    uint32_t table = 1;
    while (uint64_t(table) < 2 * uint64_t(n)) table <<= 1;
    const uint32_t mask = table - 1;
    if (compact_.size() < n) compact_.resize(n);
    if (keys_.size() < n) keys_.resize(n);
    if (values_.size() < n) values_.resize(n);
    if (sorted_.size() < n) sorted_.resize(n);
    cell_start_.resize(size_t(table) + 1);
    CompactPhoton* compact = compact_.data();
    uint32_t* keys = keys_.data();
    uint32_t* values = values_.data();
    b.parallel_for(n, CAUSTICA_KERNEL(uint32_t i) {
      compact[i] = encode_photon(photons[i], g.quant);
      keys[i] = grid_slot(g.cell_of(decode_position(compact[i].q, g.quant)), mask);
      values[i] = i;
    });
    b.sort_pairs(keys, values, n, key_bits_for(table), tmp_k_, tmp_v_);
    CompactPhoton* sorted = sorted_.data();
    uint32_t* cell_start = cell_start_.data();
    b.parallel_for(n, CAUSTICA_KERNEL(uint32_t j) { sorted[j] = compact[values[j]]; });
    write_run_starts(b, keys, n, table, cell_start);  // cell_start[s]: the first position with slot >= s
    view_ = shape_;
    view_.photons = sorted;
    view_.cell_start = cell_start;
    view_.num_photons = n;
    view_.table_mask = mask;
  }

  const PhotonGridView& view() const { return view_; }
  // The view with ids() (without stochastic hashing): a query reports each record's index in build()'s input.
  PhotonGridView view_with_ids() const {
    PhotonGridView v = view_;
    v.ids = values_.data();
    return v;
  }
  // Without stochastic hashing: each record's index in build()'s input, in the grid's order (the view has
  // no ids; integrators that keep more per photon reorder their records by these).
  const uint32_t* ids() const { return values_.data(); }

  // Stochastic hashing (hash_grid.h): the photons sorted by (cell, index), one kept per cell, chosen
  // uniformly by a hash of (seed, cell), its power multiplied by the cell's photon count.
  void select_one_per_cell(const B& b, const Photon* photons, uint32_t n, uint64_t seed) {
    if (cells_.size() < n) cells_.resize(n);
    if (values_.size() < n) values_.resize(n);
    if (flags_.size() < n + 1) flags_.resize(n + 1);
    if (group_.size() < n + 1) group_.resize(n + 1);
    uint64_t* cells = cells_.data();
    uint32_t* values = values_.data();
    const PhotonGridView g = shape_;
    b.parallel_for(n, CAUSTICA_KERNEL(uint32_t i) {
      uint16_t q[3];
      encode_position(photons[i].p, g.quant, q);
      cells[i] = g.cell_of(decode_position(q, g.quant));
      values[i] = i;
    });
    b.sort_pairs(cells, values, n, 63, tmp_k64_, tmp_v_);  // cell keys have 63 bits; stable: index order
    uint32_t* flags = flags_.data();
    uint32_t* group = group_.data();
    b.parallel_for(n, CAUSTICA_KERNEL(uint32_t j) { flags[j] = (j == 0 || cells[j] != cells[j - 1]) ? 1u : 0u; });
    const uint32_t groups = b.exclusive_scan(flags, group, n);
    if (begin_.size() < groups + 1) begin_.resize(groups + 1);
    if (kept_.size() < groups) kept_.resize(groups);
    uint32_t* begin = begin_.data();
    b.parallel_for(n + 1, CAUSTICA_KERNEL(uint32_t j) {
      if (j == n) begin[groups] = n;
      else if (flags[j]) begin[group[j]] = j;
    });
    Photon* kept = kept_.data();
    b.parallel_for(groups, CAUSTICA_KERNEL(uint32_t k) {
      const uint32_t lo = begin[k], count = begin[k + 1] - lo;
      // Uniform among the cell's photons (Lemire's multiply-shift maps 32 hashed bits to [0, count)).
      uint32_t h = uint32_t(hash3(seed, cells[lo], 0x73746f63ULL) >> 32);
      uint32_t pick = uint32_t((uint64_t(h) * count) >> 32);
      Photon ph = photons[values[lo + pick]];
      ph.power = ph.power * float(count);
      kept[k] = ph;
    });
    kept_count_ = groups;
  }

 private:
  PhotonGridView shape_, view_;
  Buffer<Bounds3> pb_;
  Buffer<CompactPhoton> compact_, sorted_;
  Buffer<uint32_t> keys_, values_, cell_start_, tmp_k_, tmp_v_, flags_, group_, begin_;
  Buffer<uint64_t> cells_, tmp_k64_;
  Buffer<Photon> kept_;
  uint32_t kept_count_ = 0;
};

template <class B>
class WavefrontPhoton {
 public:
  template <class T>
  using Buffer = typename B::template Buffer<T>;

  WavefrontPhoton(const B& backend, const PhotonWavefrontParams& p) : b_(backend), p_(p) {
    const Camera& c = b_.scene().camera;
    n_ = uint32_t(c.width) * uint32_t(c.height);
    K_ = p_.ppm ? uint32_t(kPpmPointsPerPixel) : 1u;
    if (uint64_t(n_) * K_ > 0xffffffffull) throw InputError("ppm on the wavefront: at most 536870911 pixels");
    nk_ = n_ * K_;
    if (p_.pm && p_.k > uint32_t(kWavefrontMaxK))
      throw InputError("--k: at most " + std::to_string(kWavefrontMaxK) + " photons per estimate on the wavefront, got " +
                       std::to_string(p_.k));
    vbase_ = p_.ppm ? nk_ : 0u;
    if (p_.ppm && p_.media && uint64_t(nk_) + n_ > 0xffffffffull)
      throw InputError("ppm on the wavefront in media: at most 477218588 pixels");
    nvp_ = nk_ + (p_.ppm && p_.media ? n_ : 0u);
    if (!p_.pm) vp_.resize(nvp_);
    lpass_.resize(3 * size_t(n_));
    direct_.resize(3 * size_t(n_));
    if (p_.pm) {
    } else if (p_.pppm) {
      indirect_.resize(3 * size_t(n_));
    } else {
      N_.resize(nk_);
      tau_.resize(3 * size_t(nk_));
      R_.resize(nk_);
      if (p_.media) {  // sppm, ppm in media: the volume visible points' statistics, one set per pixel
        Nv_.resize(n_);
        tauv_.resize(3 * size_t(n_));
        Rv_.resize(n_);
      }
    }
    const uint32_t P = p_.photons;
    paths_.resize(P);
    hits_.resize(P);
    staged_.resize(P);
    queue_.resize(P);
    queue2_.resize(P);
    flags_.resize(P);
    scan_.resize(P);
    payload_cap_ = p_.adaptive_payload > 0 ? p_.adaptive_payload : 1;
    deposit_cap_ = p_.adaptive_deposits > 0
                       ? p_.adaptive_deposits
                       : 4 * adaptive_chain_steps(P, adaptive_chain_count(P), 0);  // chain 0 is the longest
    reset();
  }

  // The per-pixel statistics' arrays, for kernels to capture (the unused ones are null). Public, as every
  // type a device lambda captures must be.
  struct PixelStats {
    double *direct, *indirect, *N, *tau;
    float* R;
    double *Nv, *tauv;  // sppm, ppm in media: the volume visible points' statistics (per pixel)
    float* Rv;
  };
  PixelStats pixel_stats() {
    return {direct_.data(), indirect_.data(), N_.data(), tau_.data(), R_.data(), Nv_.data(), tauv_.data(), Rv_.data()};
  }

  // No light, no flux, every radius r0 (a member function of its own: nvcc's device lambdas may not live
  // in constructors).
  // Per visible point (ppm: K per pixel, pixel i's at i * K + k, in media then one volume point per pixel);
  // direct light per pixel.
  void reset() {
    const PixelStats ps = pixel_stats();
    const bool pppm = p_.pppm;
    const float r0 = p_.radius;
    const uint32_t K = K_;
    const bool pm = p_.pm;
    const bool volume_stats = !p_.pppm && !p_.pm && p_.media;
    const float rv0 = p_.volume_radius;
    VisiblePoint* vp = vp_.data();
    const uint32_t nk = nk_;
    b_.parallel_for(nvp_, CAUSTICA_KERNEL(uint32_t j) {
      if (!pm) vp[j] = VisiblePoint();
      if (j >= nk) return;  // ppm's volume points: their statistics are per pixel, below
      if (j % K == 0)
        for (int c = 0; c < 3; ++c) ps.direct[3 * size_t(j / K) + c] = 0.0;
      if (pm) return;
      if (pppm) {
        for (int c = 0; c < 3; ++c) ps.indirect[3 * size_t(j) + c] = 0.0;
      } else {
        ps.N[j] = 0.0;
        for (int c = 0; c < 3; ++c) ps.tau[3 * size_t(j) + c] = 0.0;
        ps.R[j] = r0;
        if (volume_stats && j % K == 0) {
          j /= K;  // the pixel
          ps.Nv[j] = 0.0;
          for (int c = 0; c < 3; ++c) ps.tauv[3 * size_t(j) + c] = 0.0;
          ps.Rv[j] = rv0;
        }
      }
    });
  }

  bool render_pass(uint32_t pass, const std::atomic<bool>* cancel, WavefrontPassStats& stats) {
    const SceneView s = b_.scene();
    const auto tracer = b_.tracer();
    const int64_t abs_pass = p_.pass_offset + int64_t(pass);
    const uint32_t W = uint32_t(s.camera.width);
    const uint32_t max_depth = p_.max_depth;
    stats = WavefrontPassStats();
    auto cancelled = [&] { return cancel && cancel->load(std::memory_order_relaxed); };
    StageClock<B> clock(b_);
    if (p_.pm) return render_pm_pass(s, tracer, abs_pass, cancel, clock, stats);

    // Visible points: a new camera path per pixel (its direct light kept apart until the pass completes).
    // ppm keeps the measurement points of its first pass (Hachisuka et al. 2008, Sec. 4.1; a cancelled first
    // pass traces them again) and re-estimates only the direct light, as photon_render.cpp does.
    {
      PathParams pp;
      pp.seed = p_.seed;
      pp.sampler = p_.sampler;
      VisiblePoint* vp = vp_.data();
      double* lpass = lpass_.data();
      const bool light_bvh = p_.light_bvh;
      const bool ppm = p_.ppm, measure = p_.ppm && (!measured_ || p_.grid_media);
      const bool volume_points = p_.ppm && p_.media;
      const bool hide = p_.hide_emitters;
      const uint32_t vbase = vbase_;
      const int K = int(K_);
      b_.parallel_for(n_, CAUSTICA_KERNEL(uint32_t i) {
        PathState st;
        path_start(s, pp, i % W, i / W, uint32_t(abs_pass), st);
        const Ray camera_ray = st.ray;
        RGB L(0.f);
        const VisiblePoint v =
            trace_camera(s, tracer, st.ray, RGB(st.weight), st.sampler, max_depth, L, light_bvh, true, kCameraMedium, hide);
        if (!ppm) vp[i] = v;
        if (volume_points) vp[vbase + i] = v.volume ? v : VisiblePoint();
        if (measure) {
          VisiblePoint* out = vp + size_t(i) * K;
          const int m = trace_measurement_points(s, tracer, camera_ray, max_depth, out, K, uint64_t(abs_pass) + 1);
          for (int k = m; k < K; ++k) out[k] = VisiblePoint();
        }
        bool ok = isfinite3(L);
        for (int c = 0; c < 3; ++c) lpass[3 * size_t(i) + c] = ok ? double(L[c]) : 0.0;
      });
    }
    clock.lap(stats.seconds_visible);
    if (cancelled()) return false;

    // Photon paths, one segment per stage. A photon stored after k segments completes a path of k + 1
    // segments with a first-hit visible point: paths of at most max_depth - 1 segments (as the CPU driver).
    // With --photon-sampling adaptive the paths are drawn by Markov chains on their visibility to the
    // visible points within the largest radius (trace_photons_adaptive).
    const uint32_t photon_depth = max_depth == 0xffffffffu ? max_depth : max_depth - 1;
    const uint32_t P = p_.photons;
    const float rmax = p_.pppm ? pppm_radius(p_.radius, p_.alpha, abs_pass) : b_.reduce(R_.data(), nk_, 0.f, FloatMax());
    const float rv = !p_.media ? 0.f
                     : p_.pppm ? pppm_volume_radius(p_.volume_radius, p_.alpha, abs_pass)
                               : b_.reduce(Rv_.data(), n_, 0.f, FloatMax());
    uint32_t count = 0;
    if (p_.adaptive ? !trace_photons_adaptive(abs_pass, photon_depth, rmax, rv, cancel, stats, count)
                    : !trace_photons(uint32_t(abs_pass), photon_depth, false, cancel, stats, count))
      return false;
    stats.photons = P;
    stats.stored_photons = count;
    clock.lap(stats.seconds_photons);
    if (cancelled()) return false;

    // In media: the volume photons to a grid of their own (stable: both keep the photons' order).
    const Photon* surface = photons_.data();
    if (p_.media) {
      for (Buffer<uint32_t>* buf : {&split_flags_, &split_scan_, &split_index_})
        if (buf->size() < count + 1) buf->resize(count + 1);
      if (split_.size() < count) split_.resize(count);
      const Photon* all = photons_.data();
      uint32_t* flags = split_flags_.data();
      uint32_t* index = split_index_.data();
      b_.parallel_for(count, CAUSTICA_KERNEL(uint32_t k) { flags[k] = (all[k].flags & kPhotonVolume) ? 1u : 0u; });
      // The surface photons, then the volume photons, each in the photons' order.
      const uint32_t nv = stable_partition(b_, flags, split_scan_.data(), index, count);
      Photon* sp = split_.data();
      b_.parallel_for(count, CAUSTICA_KERNEL(uint32_t j) { sp[j] = all[index[j]]; });
      count -= nv;
      volume_grid_.build(b_, sp + count, nv, s.bounds, 2.f * rv, p_.stochastic_hash,
                         hash3(p_.seed, uint64_t(abs_pass), 0x9e));
      surface = sp;
    }
    // The grid, with cells of twice the largest radius (a query then overlaps at most 2x2x2 cells).
    grid_.build(b_, surface, count, s.bounds, 2.f * rmax, p_.stochastic_hash,
                hash3(p_.seed, uint64_t(abs_pass), 0x9d));
    clock.lap(stats.seconds_grid);
    if (cancelled()) return false;

    // Gather and update: the last stage, so a cancelled pass changes nothing.
    {
      const PhotonGridView g = grid_.view();
      const PhotonGridView vg = p_.media ? volume_grid_.view() : PhotonGridView();
      const VisiblePoint* vp = vp_.data();
      const double* lpass = lpass_.data();
      const PixelStats ps = pixel_stats();
      const bool pppm = p_.pppm;
      const float alpha = p_.alpha;
      const double inv_np = 1.0 / double(P);
      const uint32_t K = K_, nk = nk_, vbase = vbase_, max_depth = p_.max_depth;
      // i: the visible point (pixel i / K; ppm's volume points after nk, pixel i - vbase)
      b_.parallel_for(nvp_, CAUSTICA_KERNEL(uint32_t i) {
        if (i < nk && i % K == 0)
          for (int c = 0; c < 3; ++c) ps.direct[3 * size_t(i / K) + c] += lpass[3 * size_t(i / K) + c];
        if (!vp[i].valid) return;
        double phi[3];
        uint32_t M;
        if (vp[i].volume) {  // in media (sppm.h): pixel j's (pppm and sppm: K is 1, j = i)
          const uint32_t j = i - vbase;
          sppm_volume_gather(vp[i], s, vg, pppm ? rv : ps.Rv[j], max_depth, phi, M);
          if (pppm) pppm_add_volume(&ps.indirect[3 * size_t(j)], vp[i].beta, phi, inv_np, rv);
          else sppm_update(ps.Nv[j], &ps.tauv[3 * size_t(j)], ps.Rv[j], vp[i].beta, phi, M, alpha, 3);
          return;
        }
        float radius = pppm ? rmax : ps.R[i];
        sppm_gather(vp[i], g, radius, max_depth, phi, M);
        if (pppm) pppm_add(&ps.indirect[3 * size_t(i)], vp[i].beta, phi, inv_np, radius);
        else sppm_update(ps.N[i], &ps.tau[3 * size_t(i)], ps.R[i], vp[i].beta, phi, M, alpha);
      });
    }
    clock.lap(stats.seconds_gather);
    measured_ = true;
    if (p_.adaptive) chains_.commit(pass_counts_);
    return true;
  }

  // Traces photon paths [0, p_.photons) of pass `pass_index` (photon/trace.h's stream for that pass) one segment
  // per stage; the stored photons go to photons_[0, count) in (depth, path) order. keep_direct: also the
  // light's direct photons (pm's global map; the others leave direct light to NEE). False when cancelled.
  bool trace_photons(uint32_t pass_index, uint32_t photon_depth, bool keep_direct, const std::atomic<bool>* cancel,
                     WavefrontPassStats& stats, uint32_t& count) {
    const SceneView s = b_.scene();
    const auto tracer = b_.tracer();
    const uint32_t P = p_.photons;
    auto cancelled = [&] { return cancel && cancel->load(std::memory_order_relaxed); };
    count = 0;
    {
      PhotonPathState* paths = paths_.data();
      uint32_t* queue = queue_.data();
      const uint64_t seed = p_.seed;
      const bool media = p_.media;
      const int32_t outside = p_.outer_medium;
      b_.parallel_for(P, CAUSTICA_KERNEL(uint32_t i) {
        photon_start(s, seed, pass_index, i, paths[i]);
        if (photon_depth == 0) paths[i].active = false;
        if (media && paths[i].active)
          paths[i].medium = locate_medium(s, TracerIntersect<decltype(tracer)>{tracer}, paths[i].ray, outside);
        queue[i] = i;
      });
    }
    uint32_t len = P;
    for (uint32_t depth = 0; len > 0; ++depth) {
      if (cancelled()) return false;
      PhotonPathState* paths = paths_.data();
      Hit* hits = hits_.data();
      Photon* staged = staged_.data();
      uint32_t* queue = queue_.data();
      uint32_t* flags = flags_.data();
      uint32_t* scan = scan_.data();
      b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
        uint32_t i = queue[k];
        if (paths[i].active) tracer.intersect(paths[i].ray, hits[i]);
      });
      // Rays traced: after the first compaction every queued path is active; at depth 0 some paths may have
      // emitted nothing (counted with a scan, once).
      if (depth == 0) {
        b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) { flags[k] = paths[queue[k]].active ? 1u : 0u; });
        stats.rays += b_.exclusive_scan(flags, scan, len);
      } else {
        stats.rays += len;
      }
      b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
        uint32_t i = queue[k];
        bool stored = false;
        if (paths[i].active) {
          Photon ph;
          stored = photon_bounce(s, photon_depth, paths[i], hits[i], ph) && (keep_direct || !(ph.flags & kPhotonDirect));
          if (stored) staged[k] = ph;
        }
        flags[k] = stored ? 1u : 0u;
      });
      const uint32_t stored = b_.exclusive_scan(flags, scan, len);
      reserve_photons(size_t(count) + stored);
      {
        Photon* out = photons_.data() + count;
        b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
          if (flags[k]) out[scan[k]] = staged[k];
        });
      }
      count += stored;
      len = compact_queue(b_, paths, queue_, queue2_, flags, scan, len);  // the paths still going
    }
    return true;
  }

  // --photon-sampling adaptive (Hachisuka & Jensen 2011): pass `abs_pass`'s photon paths drawn by
  // adaptive_chain_count(photons) Markov chains on their visibility to the pass's visible points within
  // their radii (rmax: the largest), one thread per chain running all its steps, with the CPU driver's stage
  // function (adaptive_photons.h: run_adaptive_photon_chain) and numbers. A chain's two payloads and its
  // deposits live in fixed regions; a chain that needs more (a path with more visible photons, more
  // deposits) runs on to its end counting, the regions grow to what the chains needed and every chain runs
  // again (the same numbers, so the same photons). The deposits, concatenated in chain order and scaled by
  // n_vis / S (photon/adaptive.h), become photons_[0, count): the CPU driver's photons in its order. The
  // chains' counts wait in pass_counts_ until the pass completes (render_pass commits them: the mutation
  // size for the next pass adapts to this pass's acceptance). Few threads (at most 128
  // chains) but exact parity with the CPU driver. False when cancelled: checked between stages and, on the
  // CPU backend, by every chain each 256 steps (HostCancelFlag), so Ctrl-C stops a long pass as promptly as
  // the CPU driver's; a CUDA kernel runs its chains to the end.
  bool trace_photons_adaptive(int64_t abs_pass, uint32_t photon_depth, float rmax, float rv,
                              const std::atomic<bool>* cancel, WavefrontPassStats& stats, uint32_t& count) {
    const SceneView s = b_.scene();
    const auto tracer = b_.tracer();
    auto cancelled = [&] { return cancel && cancel->load(std::memory_order_relaxed); };
    count = 0;
    // The valid visible points (surface and volume ones) in index order, and a grid over them that keeps
    // their ids.
    AdaptiveVisibility visible;
    visible.set_radii(s.bounds, rmax, rv);
    visible.max_depth = p_.max_depth;
    {
      if (point_flags_.size() < nvp_) point_flags_.resize(nvp_);
      if (point_scan_.size() < nvp_) point_scan_.resize(nvp_);
      const VisiblePoint* vp = vp_.data();
      uint32_t* flags = point_flags_.data();
      uint32_t* scan = point_scan_.data();
      b_.parallel_for(nvp_, CAUSTICA_KERNEL(uint32_t i) { flags[i] = vp[i].valid ? 1u : 0u; });
      const uint32_t points = b_.exclusive_scan(flags, scan, nvp_);
      if (points_.size() < points) points_.resize(points);
      if (point_vp_.size() < points) point_vp_.resize(points);
      Photon* pts = points_.data();
      uint32_t* pvp = point_vp_.data();
      b_.parallel_for(nvp_, CAUSTICA_KERNEL(uint32_t i) {
        if (!flags[i]) return;
        Photon p;
        p.p = vp[i].p;
        pts[scan[i]] = p;
        pvp[scan[i]] = i;
      });
      if (points > 0) {
        point_grid_.build(b_, points_.data(), points, s.bounds, 2.f * visible.query_radius, false, 0);
        visible.points = point_grid_.view_with_ids();
      }
      visible.point_vp = point_vp_.data();
      visible.vp = vp;
      visible.R = p_.pppm ? nullptr : R_.data();
      visible.Rv = p_.media && !p_.pppm ? Rv_.data() : nullptr;
      visible.volume_base = vbase_;
    }
    if (cancelled()) return false;

    const uint64_t P = p_.photons;
    const uint32_t chains = adaptive_chain_count(P);
    const float d = chains_.mutation_size;
    const uint64_t seed = p_.seed;
    const int32_t outside = p_.outer_medium;
    if (samples_.size() < 2 * size_t(chains)) samples_.resize(2 * size_t(chains));
    if (chain_results_.size() < chains) chain_results_.resize(chains);
    std::vector<AdaptiveChainResult> results(chains);
    for (;;) {
      if (payloads_.size() < 2 * size_t(chains) * payload_cap_) payloads_.resize(2 * size_t(chains) * payload_cap_);
      if (deposits_.size() < size_t(chains) * deposit_cap_) deposits_.resize(size_t(chains) * deposit_cap_);
      PrimarySample* samples = samples_.data();
      Photon* payloads = payloads_.data();
      Photon* deposits = deposits_.data();
      AdaptiveChainResult* out = chain_results_.data();
      const uint32_t pcap = payload_cap_;
      const uint64_t dcap = deposit_cap_;
      const HostCancelFlag host_cancel{cancel};
      b_.parallel_for_long(chains, CAUSTICA_KERNEL(uint32_t c) {
        AdaptiveChainResult r;
        PhotonSlot slots[2];
        for (int k = 0; k < 2; ++k) {
          slots[k].photons = payloads + (2 * size_t(c) + k) * pcap;
          slots[k].cap = pcap;
        }
        Photon* region = deposits + size_t(c) * dcap;
        const CountingTracer<decltype(tracer)> counting{tracer, &r.rays};
        run_adaptive_photon_chain(
            s, counting, visible, photon_depth, seed, abs_pass, c, adaptive_chain_steps(P, chains, c), d,
            samples + 2 * size_t(c), slots,
            [&](const PhotonSlot& state) {
              if (state.n > r.payload) r.payload = state.n;
              for (uint32_t j = 0; j < state.n; ++j, ++r.deposited)
                if (j < state.cap && r.deposited < dcap) region[r.deposited] = state.photons[j];
            },
            host_cancel, r.counts, outside);

        out[c] = r;
      });
      b_.to_host(chain_results_, results.data(), chains);
      uint64_t need_payload = 0, need_deposits = 0;
      for (const AdaptiveChainResult& r : results) {
        need_payload = r.payload > need_payload ? r.payload : need_payload;
        need_deposits = r.deposited > need_deposits ? r.deposited : need_deposits;
      }
      if (need_payload <= payload_cap_ && need_deposits <= deposit_cap_) break;
      if (cancelled()) return false;
      // A quarter more than needed, so that the next passes (whose chains deposit about as much) rarely
      // run twice.
      payload_cap_ = uint32_t(need_payload > payload_cap_ ? need_payload + need_payload / 4 : payload_cap_);
      deposit_cap_ = need_deposits > deposit_cap_ ? need_deposits + need_deposits / 4 : deposit_cap_;
    }
    if (cancelled()) return false;

    // The deposits in chain order, scaled.
    ChainCounts pass_counts;
    std::vector<uint64_t> start(chains + 1, 0);
    for (uint32_t c = 0; c < chains; ++c) {
      pass_counts.add(results[c].counts);
      start[c + 1] = start[c] + results[c].deposited;
      stats.rays += results[c].rays;
    }
    if (start[chains] > 0xffffffffull)
      throw std::runtime_error("adaptive photon tracing: more than 4294967295 photons stored in one pass");
    count = uint32_t(start[chains]);
    if (chain_start_.size() < chains + 1) chain_start_.resize(chains + 1);
    b_.to_device(chain_start_, start.data(), chains + 1);
    reserve_photons(count);
    {
      const uint64_t* first = chain_start_.data();
      const Photon* deposits = deposits_.data();
      const uint64_t dcap = deposit_cap_;
      const float scale = float(pass_counts.deposit_scale());
      Photon* photons = photons_.data();
      b_.parallel_for(count, CAUSTICA_KERNEL(uint32_t k) {
        uint32_t lo = 0, hi = chains;  // the chain c with first[c] <= k < first[c + 1]
        while (hi - lo > 1) {
          const uint32_t mid = (lo + hi) / 2;
          if (first[mid] <= k) lo = mid;
          else hi = mid;
        }
        Photon ph = deposits[size_t(lo) * dcap + (k - first[lo])];
        ph.power = ph.power * scale;
        photons[k] = ph;
      });
    }
    pass_counts_ = pass_counts;  // committed when the pass completes
    return true;
  }

  // What one chain of trace_photons_adaptive did: its counts, the rays it traced, the photons it deposited
  // and the most visible photons one of its paths had (both counted past the regions' sizes).
  struct AdaptiveChainResult {
    ChainCounts counts;
    uint64_t rays = 0, deposited = 0;
    uint32_t payload = 0;
  };
  // A tracer that counts its closest-hit queries.
  template <class Tracer>
  struct CountingTracer {
    Tracer t;
    uint64_t* n;
    CHD bool intersect(const Ray& ray, Hit& hit) const {
      ++*n;
      return t.intersect(ray, hit);
    }
  };

  AdaptiveSummary adaptive_summary() const {
    return p_.adaptive ? chains_.summary() : AdaptiveSummary();
  }

  // pm (Jensen 1996): the global and caustic maps built once, from photon pass 0xfffffff as the CPU driver
  // (photon_render.cpp) traces them, on the host into the portable kd-tree (photon/knn_tree.h) and copied to
  // the backend; then per pass one camera sample per pixel (pm.h's pm_radiance), its light added in the
  // last stage.
  // (Called by render_pass with its pass's scene, tracer, pass index and stage clock.)
  template <class Tracer>
  bool render_pm_pass(const SceneView s, const Tracer tracer, int64_t abs_pass, const std::atomic<bool>* cancel,
                      StageClock<B>& clock, WavefrontPassStats& stats) {
    const uint32_t W = uint32_t(s.camera.width);
    const uint32_t max_depth = p_.max_depth;
    auto cancelled = [&] { return cancel && cancel->load(std::memory_order_relaxed); };
    if (!maps_built_) {
      const uint32_t photon_depth = max_depth == 0xffffffffu ? max_depth : max_depth - 1;
      uint32_t count = 0;
      if (!trace_photons(0xfffffffu, photon_depth, true, cancel, stats, count)) return false;
      clock.lap(stats.seconds_photons);
      std::vector<Photon> all(count);
      if (count > 0) b_.to_host(photons_, all.data(), count);
      const PmPhotonSplit maps = pm_split_photons(all);
      upload_map(build_knn_tree(maps.global), global_);
      upload_map(build_knn_tree(maps.caustic), caustic_);
      upload_map(build_knn_tree(maps.volume), volume_);
      upload_map(build_knn_tree(maps.volume_indirect), volume_indirect_);
      stats.photons = p_.photons;
      stats.stored_photons = count;
      maps_built_ = true;
      clock.lap(stats.seconds_grid);
      if (cancelled()) return false;
    }
    {
      PathParams pp;
      pp.seed = p_.seed;
      pp.sampler = p_.sampler;
      double* lpass = lpass_.data();
      const bool light_bvh = p_.light_bvh;
      const KnnTreeView global = global_.view(), caustic = caustic_.view(), volume = volume_.view(),
                        volume_indirect = volume_indirect_.view();
      const uint64_t paths = p_.photons;
      const uint32_t k = p_.k;
      const bool hide = p_.hide_emitters;
      b_.parallel_for(n_, CAUSTICA_KERNEL(uint32_t i) {
        PathState st;
        path_start(s, pp, i % W, i / W, uint32_t(abs_pass), st);
        uint32_t idx[kWavefrontMaxK];
        float d2[kWavefrontMaxK];
        const RGB L = st.weight * pm_radiance(s, tracer, PmMaps<KnnTreeView>{caustic, global, volume, volume_indirect},
                                              paths, k, st.ray, st.sampler, max_depth, light_bvh, idx, d2, hide);
        const bool ok = isfinite3(L);
        for (int c = 0; c < 3; ++c) lpass[3 * size_t(i) + c] = ok ? double(L[c]) : 0.0;
      });
    }
    clock.lap(stats.seconds_visible);
    if (cancelled()) return false;
    {
      double* direct = direct_.data();
      const double* lpass = lpass_.data();
      b_.parallel_for(3 * n_, CAUSTICA_KERNEL(uint32_t j) { direct[j] += lpass[j]; });
    }
    clock.lap(stats.seconds_gather);
    return true;
  }

  // A portable kd-tree's arrays on the backend.
  struct DeviceKnnTree {
    Buffer<Photon> photons;
    Buffer<uint32_t> index;
    Buffer<uint8_t> axis;
    uint32_t n = 0;
    KnnTreeView view() const {
      KnnTreeView v;
      v.photons = photons.data();
      v.index = index.data();
      v.axis = axis.data();
      v.n = n;
      return v;
    }
  };
  void upload_map(const KnnTreeHost& t, DeviceKnnTree& d) {
    d.n = uint32_t(t.photons.size());
    d.photons.resize(t.photons.size());
    d.index.resize(t.index.size());
    d.axis.resize(t.axis.size());
    if (d.n == 0) return;
    b_.to_device(d.photons, t.photons.data(), t.photons.size());
    b_.to_device(d.index, t.index.data(), t.index.size());
    b_.to_device(d.axis, t.axis.data(), t.axis.size());
  }

  // The statistics, copied to the host: direct (3 per pixel), and tau (3), R (1) per visible point for sppm
  // and ppm (points_per_pixel() of them per pixel) or indirect (3 per pixel) for pppm.
  // sppm and ppm in media also fill tau_v (3) and R_v (1) per pixel, their volume visible points' statistics.
  void statistics(std::vector<double>& direct, std::vector<double>& tau, std::vector<float>& R,
                  std::vector<double>& indirect, std::vector<double>& tau_v, std::vector<float>& R_v) const {
    direct.resize(3 * size_t(n_));
    b_.to_host(direct_, direct.data(), direct.size());
    if (p_.pm) {
    } else if (p_.pppm) {
      indirect.resize(3 * size_t(n_));
      b_.to_host(indirect_, indirect.data(), indirect.size());
    } else {
      tau.resize(3 * size_t(nk_));
      R.resize(nk_);
      b_.to_host(tau_, tau.data(), tau.size());
      b_.to_host(R_, R.data(), R.size());
      if (p_.media) {
        tau_v.resize(3 * size_t(n_));
        R_v.resize(n_);
        b_.to_host(tauv_, tau_v.data(), tau_v.size());
        b_.to_host(Rv_, R_v.data(), R_v.size());
      }
    }
  }

  int points_per_pixel() const { return int(K_); }

  // Grows the photon array keeping its contents (public: nvcc's device lambdas may not live in private
  // member functions).
  void reserve_photons(size_t n) { reserve_keep(b_, photons_, n, photons_.size(), size_t(p_.photons) * 2 + 1024); }

 private:
  const B& b_;
  PhotonWavefrontParams p_;
  uint32_t n_ = 0;   // pixels
  uint32_t K_ = 1;   // visible points per pixel (ppm: kPpmPointsPerPixel)
  uint32_t nk_ = 0;  // visible points per pass (ppm: its measurement points)
  uint32_t nvp_ = 0;    // all visible points: nk_, and ppm in media one volume point per pixel after them
  uint32_t vbase_ = 0;  // a volume visible point i is pixel i - vbase_'s (ppm: nk_; pppm, sppm: 0, K_ is 1)
  bool measured_ = false;  // ppm: the measurement points are traced (a pass has completed)
  bool maps_built_ = false;  // pm: the photon maps are built
  DeviceKnnTree global_, caustic_, volume_, volume_indirect_;  // pm's maps (pm.h)
  // --photon-sampling adaptive: the chains' state over passes, the regions' sizes (grown as needed), buffers.
  AdaptiveChainState chains_;
  ChainCounts pass_counts_;  // the current pass's, until it completes
  uint32_t payload_cap_ = 1;  // set from p_ in the constructor
  uint64_t deposit_cap_ = 1;
  Buffer<PrimarySample> samples_;
  Buffer<Photon> payloads_, deposits_, points_;
  Buffer<AdaptiveChainResult> chain_results_;
  Buffer<uint64_t> chain_start_;
  Buffer<uint32_t> point_flags_, point_scan_, point_vp_;
  BackendPhotonGrid<B> point_grid_;
  Buffer<VisiblePoint> vp_;
  Buffer<double> lpass_, direct_, indirect_, N_, tau_, Nv_, tauv_;
  Buffer<float> R_, Rv_;
  Buffer<PhotonPathState> paths_;
  Buffer<Hit> hits_;
  Buffer<Photon> staged_, photons_;
  Buffer<uint32_t> queue_, queue2_, flags_, scan_;
  BackendPhotonGrid<B> grid_;
  // pppm and sppm in media: the pass's photons split into surface and volume photons, the volume photons' grid
  Buffer<Photon> split_;  // the surface photons, then the volume photons (stable_partition)
  Buffer<uint32_t> split_flags_, split_scan_, split_index_;
  BackendPhotonGrid<B> volume_grid_;
};

}  // namespace caustica
