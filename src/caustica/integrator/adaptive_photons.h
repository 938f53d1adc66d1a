// Stage functions of adaptive photon tracing (Hachisuka & Jensen 2011, "Robust Adaptive Photon Tracing using
// Photon Path Visibility"; the Markov chain and its normalisation: photon/adaptive.h) shared by the CPU
// driver (photon_render.cpp) and the wavefront driver (wavefront_photon.h) on every backend:
//   AdaptiveVisibility         V(u)'s test for one stored photon: some visible point of the pass would
//                              gather it (within its radius, with a nonzero BSDF value for its direction)
//   run_adaptive_photon_chain  one chain of a pass: its PCG32 stream from (seed, pass, chain), photon paths
//                              traced from primary samples, the visible photons of each path kept in a
//                              payload, the chain's state deposited every step
// Both drivers run the same chains with the same numbers, so their photons are the same, in the same
// order (chain by chain, step by step).
#pragma once
#include <atomic>
#include <cstdint>

#include "../base/host_device.h"
#include "../base/math.h"
#include "../photon/adaptive.h"
#include "../photon/compact_photon.h"
#include "../photon/hash_grid.h"
#include "../photon/trace.h"
#include "sppm.h"

namespace caustica {

// V(u) for one stored photon: a visible point i lies within R_i (pppm: the pass's global radius) plus
// `margin` of it and its BSDF passes light from the photon's direction; in media, a volume photon's test is
// against the volume visible points within their volume radius (sppm_volume_gather: R_v,i, or pppm's global
// r_v), the phase function being positive everywhere. The gather (sppm_gather) measures
// from the photon's quantized position (compact_photon.h: within |extent| / 65535 of the exact one); the
// test here, on exact positions, takes R_i + margin with twice that error, so it is never 0 for a photon
// that would be gathered (a larger V costs efficiency, not bias). The BSDF is evaluated as sppm_gather
// does, on the direction the grid will store (the octahedral encoding), so a photon on the far side of a
// thin wall, whose one-sided BSDF there is 0, does not make its path visible, and a photon too deep for a
// visible point's path budget (max_depth, photon.h's photon_budget) is not visible to it.
struct AdaptiveVisibility {
  PhotonGridView points;               // the valid visible points' positions; ids index point_vp
  const uint32_t* point_vp = nullptr;  // a grid id's visible point
  const VisiblePoint* vp = nullptr;
  const float* R = nullptr;            // each visible point's radius; null: every radius is rmax (pppm)
  // In media: each volume visible point's radius (sppm and ppm; null: every one is rvmax, pppm), volume visible
  // point i's at Rv[i - volume_base] (sppm: 0, a pixel's one visible point; ppm: the measurement points'
  // count, its per-pass volume points follow them, one per pixel).
  const float* Rv = nullptr;
  uint32_t volume_base = 0;
  float rmax = 0.f, rvmax = 0.f, margin = 0.f, query_radius = 0.f;
  uint32_t max_depth = 0xffffffffu;  // the render's (0xffffffff: unlimited)

  // margin and query_radius for the scene's bounds and the pass's largest radii (surface, volume); the
  // query radius also covers the quantization of the visible points' own positions in the grid over them
  // (cells of twice it).
  CHD void set_radii(const Bounds3& scene_bounds, float largest_radius, float largest_volume_radius = 0.f) {
    rmax = largest_radius;
    rvmax = largest_volume_radius;
    const float r = maxf(rmax, rvmax);
    const Vec3f ext = scene_bounds.hi - scene_bounds.lo;
    margin = 2.f * length(ext) / 65535.f + 1e-6f * r;
    query_radius = r + 2.f * margin;
  }

  CHD bool operator()(const Photon& ph) const {
    uint16_t oct[2];
    oct_encode(ph.wi, oct);
    const Vec3f wi = oct_decode(oct);
    const bool volume = (ph.flags & kPhotonVolume) != 0;
    return points.query_any(ph.p, query_radius, [&](uint32_t id, const Photon&) {
      const uint32_t i = point_vp[id];
      if (vp[i].volume != volume) return false;
      if (photon_segments(ph) > photon_budget(max_depth, vp[i].depth)) return false;
      const float r = (volume ? (Rv ? Rv[i - volume_base] : rvmax) : (R ? R[i] : rmax)) + margin;
      if (photon_dist2(ph.p, vp[i].p) > r * r) return false;
      if (volume) return true;
      const VisiblePoint& v = vp[i];
      const Frame frame = tangent_frame(v.ns, v.tangent);
      return !is_black(bsdf_eval(v.material, frame.to_local(v.wo), frame.to_local(wi), TransportMode::kRadiance));
    });
  }
};

// A payload in fixed memory (the wavefront's: one region per chain and buffer): the first `cap` photons of
// a path are kept, n counts them all (n > cap: the region was too small, and the chain must run again
// with a larger one).
struct PhotonSlot {
  Photon* photons = nullptr;
  uint32_t cap = 0, n = 0;
  CHD void clear() { n = 0; }
  CHD void push(const Photon& ph) {
    if (n < cap) photons[n] = ph;
    ++n;
  }
};

// The steps of chain c when a pass of `photons` steps runs `chains` chains: an even share, the first
// photons % chains chains one more.
CHD uint64_t adaptive_chain_steps(uint64_t photons, uint32_t chains, uint32_t c) {
  return photons / chains + (c < photons % chains ? 1 : 0);
}

// A host cancel flag that a kernel may poll: on the CPU backend the render's own flag (so a long adaptive
// pass stops within 256 chain steps of Ctrl-C, as the CPU driver's chains do); in device code there is no
// host memory to read and it is never set (the wavefront checks the flag between stages instead).
struct HostCancelFlag {
  const std::atomic<bool>* flag = nullptr;
  CHD bool operator()() const {
#if defined(__CUDA_ARCH__)
    return false;
#else
    return flag && flag->load(std::memory_order_relaxed);
#endif
  }
};

// Runs chain `chain` of pass `abs_pass` (photon/adaptive.h's run_visibility_chain) on photon paths of at most
// `photon_depth` segments. A path's photons that `visible` accepts, other than its direct ones (direct
// light is NEE's, as with uniform tracing), go to its payload (Payload: clear(), push(const Photon&)); the
// path is visible when it has one. `deposit(const Payload&)` receives the chain's state at every step that
// has one. samples[0..1], payloads[0..1]: the chain's two buffers. False when `cancelled()` became true.
// `outside`: trace_photon_path's (scenes with media).
template <typename Tracer, typename Payload, typename Deposit, typename Cancelled>
CHD bool run_adaptive_photon_chain(const SceneView& s, const Tracer& accel, const AdaptiveVisibility& visible,
                                   uint32_t photon_depth, uint64_t seed, int64_t abs_pass, uint32_t chain,
                                   uint64_t steps, float d, PrimarySample* samples, Payload* payloads,
                                   Deposit&& deposit, Cancelled&& cancelled, ChainCounts& counts,
                                   int32_t outside = -1) {
  PCG32 rng(hash3(seed, uint64_t(abs_pass), 0xada9000000000000ULL | chain), mix64(uint64_t(abs_pass) << 32 | chain));
  auto evaluate = [&](const PssStream& stream, Payload& out) {
    out.clear();
    PhotonPathStateT<PssStream> st;
    st.rng = stream;
    photon_emit(s, st);
    bool vis = false;
    trace_photon_path(
        s, st, photon_depth, [&](const Ray& ray, Hit& h) { return accel.intersect(ray, h); },
        [&](const Photon& ph) {
          if (ph.flags & kPhotonDirect) return;
          if (!visible(ph)) return;
          out.push(ph);
          vis = true;
        },
        outside);
    return vis;
  };
  return run_visibility_chain(rng, steps, d, samples, payloads, evaluate, deposit, cancelled, counts);
}

}  // namespace caustica
