// Light tracing, bidirectional path tracing, bidirectional photon mapping and vertex connection and
// merging (vcm.h: Veach 1997 Ch. 10; Georgiev, Krivanek, Davidovic & Slusallek 2012; Georgiev's
// "Implementing VCM" report for the MIS quantities), and unbiased photon gathering combined with BDPT
// (upg.h: Qin, Sun, Hou, Guo & Zhou 2015), as wavefronts over the backend interface (backend/backend.h).
// The stage functions are the CPU drivers' (vcm_render.cpp, upg_render.cpp); this file only orders them
// into passes over queues, so the CPU backend reproduces the CPU drivers bit for bit
// (tests/cpp/test_wavefront.cpp). One pass:
//   light subpaths  one segment per stage over a queue of paths (vcm_light_start, then per depth:
//                   intersect; vcm_light_hit, vcm_light_to_camera with its visibility ray,
//                   vcm_light_continue; the stored vertices and unoccluded splats appended by prefix sums
//                   of their flags; compaction). They land in (depth, path) order; a stable radix sort by
//                   path index puts them in the CPU driver's path order (depth order within a path), and
//                   the path's vertex range comes from the run starts of the sorted keys
//   merge grid      bpm, vcm: the photon hash grid (wavefront_photon.h's BackendPhotonGrid, the
//                   construction of hash_grid.h) over the vertices, cells of 2r, and the merge records
//                   (VcmMergeVertex) in the grid's order; upg: cells of 2(r + slack), reporting vertex
//                   indices
//   camera subpaths one per pixel, one segment per stage: intersect; then vcm_camera_hit, next-event
//                   estimation, the connections to every vertex of light subpath (pixel mod n_light) and
//                   the merges, each visibility ray traced in the same thread (the CPU driver's order of
//                   additions to the path's radiance), vcm_camera_continue; compaction. upg gathers at
//                   each eye hit from the previous non-delta eye vertex first (upg_gather_all: trial rays
//                   in the same thread), then connects as bdpt
//   accumulation    each splat's pixels (vcm_splat_pixels) listed by a prefix sum of their counts, stably
//                   sorted by pixel; one thread per pixel adds its camera estimate, then its splats in
//                   path order, in double precision: per pixel the CPU driver's sequence of additions,
//                   without atomics
// A pass cancelled before its last stage changes nothing. Per-strategy images are the CPU driver's alone.
#pragma once
#include <atomic>
#include <chrono>
#include <cstdint>
#include <vector>

#include "../backend/backend.h"
#include "../backend/backend_algorithms.h"
#include "upg.h"
#include "vcm.h"
#include "vcm_render.h"
#include "wavefront_photon.h"
#include "wavefront_render.h"

namespace caustica {

template <class B>
class WavefrontVcm {
 public:
  template <class T>
  using Buffer = typename B::template Buffer<T>;

  WavefrontVcm(const B& backend, const VcmWavefrontParams& p) : b_(backend), p_(p) {
    const Camera& c = b_.scene().camera;
    n_ = uint32_t(c.width) * uint32_t(c.height);
    sum_.resize(3 * size_t(n_));
    cam_.resize(n_);
    const uint32_t nl = p_.light_paths;
    light_.resize(nl);
    const uint32_t q = nl > n_ ? nl : n_;  // queues serve both kinds of subpath
    hits_.resize(q);
    queue_.resize(q);
    queue2_.resize(q);
    flags_.resize(q);
    scan_.resize(q);
    flags2_.resize(q);
    scan2_.resize(q);
    if (p_.base.mode == VcmMode::kUpg) {
      prev_.resize(n_);
      have_prev_.resize(n_);
    }
    staged_verts_.resize(nl);
    staged_splats_.resize(nl);
    start_.resize(size_t(nl) + 1);
    pixel_start_.resize(size_t(n_) + 1);
    clear();
  }

  // Zero sums (a member function of its own: nvcc's device lambdas may not live in constructors).
  void clear() {
    double* sum = sum_.data();
    b_.parallel_for(3 * n_, CAUSTICA_KERNEL(uint32_t i) { sum[i] = 0.0; });
  }

  bool render_pass(uint32_t pass, const std::atomic<bool>* cancel, WavefrontPassStats& stats) {
    const SceneView s = b_.scene();
    const auto tracer = b_.tracer();
    VcmParams p = p_.base;
    p.pass = pass;
    const bool upg = p.mode == VcmMode::kUpg;  // a fixed radius: the gather is unbiased for any r
    if (upg) vcm_set_radius(p, p_.radius);
    else
      vcm_set_radius(p, vcm_radius(p_.radius, p_.alpha, int64_t(pass)),
                     vcm_volume_radius(p_.volume_radius, p_.alpha, int64_t(pass)));
    stats = WavefrontPassStats();
    auto cancelled = [&] { return cancel && cancel->load(std::memory_order_relaxed); };
    StageClock<B> clock(b_);
    const uint32_t nl = p_.light_paths;

    // 1. Light subpaths, one segment per stage.
    const bool keep = p.use_vc() || p.use_vm();
    uint32_t nverts = 0, nsplats = 0;
    {
      VcmPathState* paths = light_.data();
      uint32_t* queue = queue_.data();
      b_.parallel_for(nl, CAUSTICA_KERNEL(uint32_t i) {
        vcm_light_start(s, p, i, paths[i]);
        vcm_light_locate(s, p, paths[i], TracerIntersect<decltype(tracer)>{tracer});
        queue[i] = i;
      });
    }
    uint32_t len = nl;
    for (uint32_t depth = 0; len > 0; ++depth) {
      if (cancelled()) return false;
      VcmPathState* paths = light_.data();
      Hit* hits = hits_.data();
      uint32_t* queue = queue_.data();
      uint32_t *flags = flags_.data(), *scan = scan_.data(), *flags2 = flags2_.data(), *scan2 = scan2_.data();
      VcmLightVertex* sv = staged_verts_.data();
      VcmSplat* ss = staged_splats_.data();
      stats.rays += intersect_queue(paths, queue, len, depth == 0);
      // flags: a vertex stored; flags2: an unoccluded splat; scan2 first counts the splats' visibility rays.
      b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
        VcmPathState& st = paths[queue[k]];
        uint32_t stored = 0, splat = 0, ray = 0;
        if (st.active) {
          if (vcm_light_hit(s, p, st, hits[queue[k]], sv[k]) && keep) stored = 1;
          if (st.active) {
            vcm_light_to_camera(s, p, st, ss[k]);
            if (ss[k].active) {
              ray = 1;
              const RGB tr = vcm_visibility(s, tracer, ss[k].ray, ss[k].medium);
              ss[k].C *= tr;
              splat = is_black(tr) ? 0u : 1u;
            }
            vcm_light_continue(s, p, st);
          }
        }
        flags[k] = stored;
        flags2[k] = splat;
        scan2[k] = ray;
      });
      stats.rays += b_.reduce(scan2, len, 0u, UintSum());
      const uint32_t v = b_.exclusive_scan(flags, scan, len);
      const uint32_t sp = b_.exclusive_scan(flags2, scan2, len);
      append(verts_in_, vkeys_, nverts, v, size_t(nl) * 2 + 1024, sv, flags, scan, queue, len);
      append(splats_in_, skeys_, nsplats, sp, size_t(nl) / 2 + 1024, ss, flags2, scan2, queue, len);
      nverts += v;
      nsplats += sp;
      len = compact(paths, len);
    }
    if (cancelled()) return false;
    // Path order (depth order within a path, as the CPU driver appends them): a stable sort by path index.
    const int path_bits = key_bits_for(nl);
    order_by_key<VcmLightVertex>(verts_in_, vkeys_, verts_, nverts, path_bits);
    order_by_key<VcmSplat>(splats_in_, skeys_, splats_, nsplats, path_bits);
    if (keep) write_run_starts(b_, vkeys_.data(), nverts, nl, start_.data());
    stats.photons = nl;
    stats.stored_photons = nverts;
    clock.lap(stats.seconds_light);

    // 2. The hash grid of light vertices for merging (cells of 2r), the merge records in the grid's order;
    // for upg's gathers, cells of 2(r + slack) and the grid reports vertex indices. In scenes with media the
    // vertices in media go to a grid of their own (cells of 2 r_v; the CPU driver's split, each part in path
    // order).
    PhotonGridView gv, gvv;
    const float query_r = p.radius + upg_query_slack(s.bounds, p.radius);
    if ((p.merges() || upg) && nverts > 0) {
      if (photons_.size() < nverts) photons_.resize(nverts);
      if (merge_verts_.size() < nverts) merge_verts_.resize(nverts);
      Photon* ph = photons_.data();
      const VcmLightVertex* verts = verts_.data();
      b_.parallel_for(nverts, CAUSTICA_KERNEL(uint32_t k) {
        Photon x;
        x.p = verts[k].sh.p;
        x.wi = verts[k].wi;
        x.power = verts[k].beta;
        ph[k] = x;
      });
      if (upg || !scene_has_media(s)) {
        grid_.build(b_, ph, nverts, s.bounds, 2.f * (upg ? query_r : p.radius), false, 0);
        gv = grid_.view();
        const uint32_t* ids = grid_.ids();
        if (upg) {
          gv.ids = ids;
        } else {
          VcmMergeVertex* mv = merge_verts_.data();
          b_.parallel_for(nverts, CAUSTICA_KERNEL(uint32_t j) { mv[j] = vcm_merge_vertex(verts[ids[j]]); });
        }
      } else {
        for (Buffer<uint32_t>* buf : {&split_flags_, &split_scan_, &split_index_})
          if (buf->size() < nverts + 1) buf->resize(nverts + 1);
        if (split_photons_.size() < nverts) split_photons_.resize(nverts);
        if (merge_verts_v_.size() < nverts) merge_verts_v_.resize(nverts);
        uint32_t* flags = split_flags_.data();
        uint32_t* scan = split_scan_.data();
        b_.parallel_for(nverts, CAUSTICA_KERNEL(uint32_t k) { flags[k] = verts[k].in_medium() ? 1u : 0u; });
        // Surface vertices first, then medium vertices, each in path order; index: a split position's vertex.
        uint32_t* index = split_index_.data();
        const uint32_t nv = stable_partition(b_, flags, scan, index, nverts), ns = nverts - nv;
        Photon* sp = split_photons_.data();
        b_.parallel_for(nverts, CAUSTICA_KERNEL(uint32_t j) { sp[j] = ph[index[j]]; });
        VcmMergeVertex* mv = merge_verts_.data();
        if (ns > 0) {
          grid_.build(b_, sp, ns, s.bounds, 2.f * p.radius, false, 0);
          gv = grid_.view();
          const uint32_t* ids = grid_.ids();
          b_.parallel_for(ns, CAUSTICA_KERNEL(uint32_t j) { mv[j] = vcm_merge_vertex(verts[index[ids[j]]]); });
        }
        if (nv > 0) {
          grid_v_.build(b_, sp + ns, nv, s.bounds, 2.f * p.radius_v, false, 0);
          gvv = grid_v_.view();
          const uint32_t* ids = grid_v_.ids();
          VcmMergeVertex* mvv = merge_verts_v_.data();
          b_.parallel_for(nv, CAUSTICA_KERNEL(uint32_t j) { mvv[j] = vcm_merge_vertex(verts[index[ns + ids[j]]]); });
        }
      }
    }
    clock.lap(stats.seconds_grid);
    if (cancelled()) return false;

    // 3. Camera subpaths, one per pixel, one segment per stage.
    {
      VcmPathState* paths = cam_.data();
      uint32_t* queue = queue_.data();
      uint32_t* have_prev = have_prev_.data();
      const uint32_t W = uint32_t(s.camera.width);
      b_.parallel_for(n_, CAUSTICA_KERNEL(uint32_t i) {
        vcm_camera_start(s, p, i % W, i / W, paths[i]);
        queue[i] = i;
        if (upg) have_prev[i] = 0;
      });
    }
    len = n_;
    for (uint32_t depth = 0; len > 0; ++depth) {
      if (cancelled()) return false;
      VcmPathState* paths = cam_.data();
      Hit* hits = hits_.data();
      uint32_t* queue = queue_.data();
      uint32_t* rays = flags_.data();
      const VcmLightVertex* verts = verts_.data();
      const uint32_t* start = start_.data();
      const VcmMergeVertex* mv = merge_verts_.data();
      const VcmMergeVertex* mvv = merge_verts_v_.data();
      VcmPathState* prev = prev_.data();
      uint32_t* have_prev = have_prev_.data();
      stats.rays += intersect_queue(paths, queue, len, depth == 0);
      b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
        const uint32_t i = queue[k];
        VcmPathState& st = paths[i];
        uint32_t r = 0;
        if (st.active) {
          vcm_camera_hit(s, p, st, hits[i]);
          // upg: the gather at this eye hit from the previous non-delta eye vertex (upg_render.cpp's order).
          if (upg && upg_gathers_at(st, hits[i], have_prev[i] != 0, prev[i])) {
            UpgGatherCounts c = upg_gather_all(s, p, prev[i], st, gv, query_r, verts, st.pixel, tracer);
            r += c.rays + c.trials;
          }
          if (st.active) {
            VcmShadow sr;
            vcm_camera_nee(s, p, st, sr);
            if (sr.active) {
              ++r;
              vcm_shadow(st, sr, vcm_visibility(s, tracer, sr.ray, sr.medium));
            }
            if (st.vertex_valid && p.use_vc()) {
              const uint32_t l = st.pixel % nl;
              for (uint32_t j = start[l]; j < start[l + 1]; ++j) {
                vcm_camera_connect(s, p, st, verts[j], sr);
                if (sr.active) {
                  ++r;
                  vcm_shadow(st, sr, vcm_visibility(s, tracer, sr.ray, sr.medium));
                }
              }
            }
            if (st.vertex_valid && p.merges()) vcm_camera_merge(s, p, st, gv, mv, gvv, mvv);
            if (upg) {
              bool hp = have_prev[i] != 0;
              upg_track_prev(st, hp, prev[i]);
              have_prev[i] = hp ? 1u : 0u;
            }
            vcm_camera_continue(s, p, st);
          }
        }
        rays[k] = r;
      });
      stats.rays += b_.reduce(rays, len, 0u, UintSum());
      len = compact(paths, len);
    }
    clock.lap(stats.seconds_camera);
    if (cancelled()) return false;

    // 4. Accumulation: per pixel its camera estimate, then its splats in path order.
    accumulate(s, p, nsplats);
    clock.lap(stats.seconds_accumulate);
    return true;
  }

  // The mean image of `passes` passes (H*W*3), as the CPU driver's mean_image.
  std::vector<float> image(int64_t passes) const {
    std::vector<double> sum(3 * size_t(n_));
    b_.to_host(sum_, sum.data(), sum.size());
    return mean_image(sum, passes);
  }

  // The stages' building blocks (public: nvcc's device lambdas may not live in private member functions).
  struct UintSum {
    CHD uint32_t operator()(uint32_t a, uint32_t b) const { return a + b; }
  };

  // Closest hits of the queued paths that are active; returns the rays traced (at depth 0 some paths may
  // not have started; after a compaction every queued path is active).
  uint64_t intersect_queue(const VcmPathState* paths, const uint32_t* queue, uint32_t len, bool first) {
    const auto tracer = b_.tracer();
    Hit* hits = hits_.data();
    uint32_t* flags = flags2_.data();
    b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
      const uint32_t i = queue[k];
      const bool active = paths[i].active;
      if (active) tracer.intersect(paths[i].ray, hits[i]);
      flags[k] = active ? 1u : 0u;
    });
    return first ? b_.reduce(flags, len, 0u, UintSum()) : len;
  }

  // Appends the staged records of queue slots k with flags[k] (at out[count + scan[k]]), keyed by their
  // path index queue[k].
  template <class T>
  void append(Buffer<T>& out, Buffer<uint32_t>& keys, uint32_t count, uint32_t added, size_t first,
              const T* staged, const uint32_t* flags, const uint32_t* scan, const uint32_t* queue, uint32_t len) {
    if (added == 0) return;
    reserve_keep(b_, out, size_t(count) + added, count, first);
    reserve_keep(b_, keys, size_t(count) + added, count, first);
    T* o = out.data() + count;
    uint32_t* kk = keys.data() + count;
    b_.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
      if (flags[k]) {
        o[scan[k]] = staged[k];
        kk[scan[k]] = queue[k];
      }
    });
  }

  // Stable sort of in[0, n) by keys (which end up sorted) into out.
  template <class T>
  void order_by_key(const Buffer<T>& in, Buffer<uint32_t>& keys, Buffer<T>& out, uint32_t n, int bits) {
    if (n == 0) return;
    if (values_.size() < n) values_.resize(n);
    if (out.size() < n) out.resize(n);
    uint32_t* values = values_.data();
    b_.parallel_for(n, CAUSTICA_KERNEL(uint32_t j) { values[j] = j; });
    b_.sort_pairs(keys.data(), values, n, bits, tmp_k_, tmp_v_);
    const T* from = in.data();
    T* to = out.data();
    b_.parallel_for(n, CAUSTICA_KERNEL(uint32_t j) { to[j] = from[values[j]]; });
  }

  // Stream compaction of the queue to the paths still active; returns their number.
  uint32_t compact(const VcmPathState* paths, uint32_t len) {
    return compact_queue(b_, paths, queue_, queue2_, flags_.data(), scan_.data(), len);
  }

  void accumulate(const SceneView& s, const VcmParams& p, uint32_t nsplats) {
    const VcmSplat* splats = splats_.data();
    uint32_t total = 0;
    if (nsplats > 0) {
      if (counts_.size() < size_t(nsplats) + 1) counts_.resize(size_t(nsplats) + 1);
      if (offsets_.size() < size_t(nsplats) + 1) offsets_.resize(size_t(nsplats) + 1);
      uint32_t* counts = counts_.data();
      uint32_t* offsets = offsets_.data();
      b_.parallel_for(nsplats, CAUSTICA_KERNEL(uint32_t k) {
        uint32_t c = 0;
        vcm_splat_pixels(s, p, splats[k], [&](uint32_t, RGB v) { c += isfinite3(v) ? 1u : 0u; });
        counts[k] = c;
      });
      total = b_.exclusive_scan(counts, offsets, nsplats);
      if (pixel_keys_.size() < total) pixel_keys_.resize(total);
      if (values_.size() < total) values_.resize(total);
      if (contrib_.size() < total) contrib_.resize(total);
      uint32_t* keys = pixel_keys_.data();
      uint32_t* values = values_.data();
      RGB* contrib = contrib_.data();
      b_.parallel_for(nsplats, CAUSTICA_KERNEL(uint32_t k) {
        uint32_t o = offsets[k];
        vcm_splat_pixels(s, p, splats[k], [&](uint32_t pix, RGB v) {
          if (!isfinite3(v)) return;
          keys[o] = pix;
          values[o] = o;
          contrib[o] = v;
          ++o;
        });
      });
      b_.sort_pairs(keys, values, total, key_bits_for(n_), tmp_k_, tmp_v_);
    }
    uint32_t* pstart = pixel_start_.data();
    write_run_starts(b_, pixel_keys_.data(), total, n_, pstart);
    const VcmPathState* cam = cam_.data();
    const uint32_t* values = values_.data();
    const RGB* contrib = contrib_.data();
    double* sum = sum_.data();
    b_.parallel_for(n_, CAUSTICA_KERNEL(uint32_t i) {
      const RGB L = cam[i].L;
      const bool ok = isfinite3(L);
      for (int c = 0; c < 3; ++c) sum[3 * size_t(i) + c] += ok ? double(L[c]) : 0.0;
      for (uint32_t j = pstart[i]; j < pstart[i + 1]; ++j) {
        const RGB v = contrib[values[j]];
        for (int c = 0; c < 3; ++c) sum[3 * size_t(i) + c] += double(v[c]);
      }
    });
  }

 private:
  const B& b_;
  VcmWavefrontParams p_;
  uint32_t n_ = 0;
  Buffer<double> sum_;
  Buffer<VcmPathState> light_, cam_;
  Buffer<Hit> hits_;
  Buffer<uint32_t> queue_, queue2_, flags_, scan_, flags2_, scan2_;
  Buffer<VcmLightVertex> staged_verts_, verts_in_, verts_;
  Buffer<VcmSplat> staged_splats_, splats_in_, splats_;
  Buffer<uint32_t> vkeys_, skeys_, start_, values_, tmp_k_, tmp_v_;
  Buffer<uint32_t> counts_, offsets_, pixel_keys_, pixel_start_, have_prev_;
  Buffer<VcmPathState> prev_;  // upg: each camera path's previous non-delta vertex
  Buffer<RGB> contrib_;
  Buffer<Photon> photons_;
  Buffer<VcmMergeVertex> merge_verts_;
  BackendPhotonGrid<B> grid_;
  // bpm, vcm in media: the vertices split into those on surfaces and those in media (flags, their scan, each
  // split position's vertex, the split photons), the medium vertices' grid and merge records.
  Buffer<uint32_t> split_flags_, split_scan_, split_index_;
  Buffer<Photon> split_photons_;
  Buffer<VcmMergeVertex> merge_verts_v_;
  BackendPhotonGrid<B> grid_v_;
};

}  // namespace caustica
