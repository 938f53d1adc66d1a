// Adaptive photon tracing: Hachisuka & Jensen 2011, "Robust Adaptive Photon Tracing using Photon Path
// Visibility" (ACM TOG 30(5)). Photon paths are points u of the primary sample space, the unit
// hypercube of the random numbers a path consumes (photon/trace.h reads them through PssStream below).
// The target is the visibility V(u): 1 when the path stores a photon that some visible point (measurement
// point) of the current pass would gather, else 0. Photons are drawn by a Markov chain whose stationary
// density is V(u) / |V|, |V| the visible fraction of the hypercube:
//   - replica exchange with a chain on the uniform density: every step draws a fresh
//     uniform u'; when V(u') = 1 the two replicas swap (the swap's acceptance V(u') / V(u) is 1), so the
//     visibility chain jumps to u' and never stays stuck in one visible region;
//   - otherwise the visibility chain mutates its state (the paper's mutation: every coordinate moves by
//     +-xi^(1/d + 1), wrapped around the unit interval, d the mutation size) and accepts the proposal when
//     it is visible (Metropolis with a symmetric proposal and a 0/1 target);
//   - adaptive MCMC (Andrieu & Thoms 2008): d is driven toward the acceptance rate 0.234 of Roberts et al.
//     1997. The paper adapts d as the chain runs (Taichi's implementation: after every mutation, with step
//     1/(mutations so far)); here d is held fixed
//     within a pass and updated between passes (adapt_mutation_size), so that within a pass every state of
//     a started chain is exactly distributed as V / |V| (see below).
// Every step deposits the chain's current state (the paper's photon of the visibility chain, repeated when
// a proposal is rejected). With n_vis of the N uniform samples visible and S the steps at which the chain
// had a state, each deposited photon's power is scaled by n_vis / S, and the pass is normalised by N
// photon paths as uniform tracing is: the estimate is (n_vis / N) x (mean over the S deposits), |V| by its
// uniform estimate times the mean of f / V under V / |V| (the paper's normalisation by the uniform replica's
// visible count).
// The paper's own text was not reachable from this project, so its section and equation numbers are not
// cited; the mutation's form was checked against Taichi's public implementation of the paper (amcmcppm).
//
// Unbiased per pass. A chain has no state at the start of a pass (visible points and radii change between
// passes, and with them V); it starts at its first visible uniform sample, which is distributed as
// V / |V|, and the steps before it deposit nothing and are not counted in S. Given the visibility of all
// uniform samples, every deposited state is then distributed as V / |V| (swaps bring in uniform samples
// conditioned on V = 1; mutations keep V / |V| invariant, d being fixed in the pass), so the expectation
// of the pass estimate given those visibilities is (n_vis / N) E_V[f / V] and, over them, |V| E_V[f / V]
// = the integral of f, that of uniform photon tracing. (If no uniform sample is visible, n_vis = 0 and the
// pass contributes nothing, as uniform tracing's photons would not either.)
//
// Primary sample vectors keep their first kPssDims coordinates (enough for (kPssDims - 6) / 4 = 30 bounces:
// emission takes 6 numbers, each bounce 4). Coordinates past those, and those a state never consumed, are
// drawn fresh for each proposal: such a coordinate is uniform and independent of V under the target, so
// drawing it anew is a Gibbs step for it and leaves V / |V| invariant (the lazy coordinates of Kelemen et
// al. 2002).
//
// Parallel and reproducible: a pass runs a fixed number of independent chains (adaptive_chain_count, from
// the photons per pass only), each on its own PCG32 stream of (seed, pass, chain); their deposits are
// concatenated in chain order, so the photons do not depend on the thread count.
#pragma once
#include <cmath>
#include <cstdint>
#include <utility>

#include "../base/host_device.h"
#include "../base/math.h"
#include "../base/rng.h"

namespace caustica {

constexpr uint32_t kPssDims = 126;
constexpr float kTargetAcceptance = 0.234f;  // Roberts, Gelman & Gilks 1997; the paper's target
constexpr float kMinMutationSize = 1e-4f, kMaxMutationSize = 1.f, kInitialMutationSize = 0.25f;

// One coordinate of a mutation: x moved by +-xi^(1/d + 1) (sign by `u_sign`, xi = `u_step`), wrapped into
// [0, 1). The step's density is the same for +t and -t, so the proposal is symmetric on the torus.
CHD float pss_mutate(float x, float d, float u_sign, float u_step) {
  float step = std::pow(u_step, 1.f / d + 1.f);
  float y = u_sign < 0.5f ? x + step : x - step;
  y -= std::floor(y);
  return y < 1.f ? y : 0.f;  // y - floor(y) rounds to 1 for tiny negative y
}

// A point of the primary sample space: the first n (<= kPssDims) coordinates a path consumed.
struct PrimarySample {
  float u[kPssDims];
  uint32_t n = 0;
};

// The random numbers of one path (the Rng of photon/trace.h's PhotonPathStateT): fresh uniform numbers from
// `rng`, or with `base`, base's coordinates mutated with size d (fresh ones past base->n). The numbers
// handed out are recorded in `out` (up to kPssDims).
struct PssStream {
  PrimarySample* out = nullptr;
  const PrimarySample* base = nullptr;
  float d = 0.f;
  PCG32* rng = nullptr;
  uint32_t i = 0;
  CHD float next_float() {
    float x;
    if (base && i < base->n) {
      float us = rng->next_float();
      x = pss_mutate(base->u[i], d, us, rng->next_float());
    } else {
      x = rng->next_float();
    }
    if (i < kPssDims) {
      out->u[i] = x;
      out->n = i + 1;
    }
    ++i;
    return x;
  }
};

// What the chains of a pass did; summed over chains (add) in chain order.
struct ChainCounts {
  uint64_t uniform = 0;           // uniform samples drawn (one per step)
  uint64_t visible = 0;           // of those, visible: n_vis
  uint64_t mutated = 0;           // proposals by mutation
  uint64_t accepted = 0;          // of those, visible (accepted)
  uint64_t steps_with_state = 0;  // S: steps that deposited the chain's state
  void add(const ChainCounts& o) {
    uniform += o.uniform;
    visible += o.visible;
    mutated += o.mutated;
    accepted += o.accepted;
    steps_with_state += o.steps_with_state;
  }
  // The factor on every deposited photon's power: n_vis / S (0 when nothing was deposited).
  double deposit_scale() const { return steps_with_state ? double(visible) / double(steps_with_state) : 0.0; }
};

// --photon-sampling adaptive over the passes so far: the visible fraction of the uniform photon paths, the
// mutations' acceptance rate, the mutation size the next pass uses (all -1 when not adaptive).
struct AdaptiveSummary {
  double visible = -1.0, acceptance = -1.0, mutation_size = -1.0;
};
// The summary of chains that made `c` over all passes, the next pass to use mutation size d.
inline AdaptiveSummary summarize_chains(const ChainCounts& c, float d) {
  AdaptiveSummary a;
  a.visible = c.uniform ? double(c.visible) / double(c.uniform) : 0.0;
  a.acceptance = c.mutated ? double(c.accepted) / double(c.mutated) : 0.0;
  a.mutation_size = d;
  return a;
}

// Runs one chain for `steps` steps. `evaluate(PssStream&, Payload&) -> bool` traces the path of the stream's
// numbers into the payload and says whether it is visible; `deposit(const Payload&)` receives the state of
// every step that has one. samples[0..1] and payloads[0..1] are the two buffers the chain alternates between.
// Returns false when `cancelled()` became true (checked every 256 steps).
template <typename Payload, typename Evaluate, typename Deposit, typename Cancelled>
CHD bool run_visibility_chain(PCG32& rng, uint64_t steps, float d, PrimarySample* samples, Payload* payloads,
                              Evaluate&& evaluate, Deposit&& deposit, Cancelled&& cancelled, ChainCounts& c) {
  int cur = 0;  // samples[cur], payloads[cur]: the state (when has_state)
  bool has_state = false;
  for (uint64_t j = 0; j < steps; ++j) {
    if ((j & 255u) == 0 && cancelled()) return false;
    const int other = cur ^ 1;
    // The uniform replica's new sample; a visible one is swapped into the visibility chain.
    PssStream uniform{&samples[other], nullptr, 0.f, &rng};
    samples[other].n = 0;
    ++c.uniform;
    if (evaluate(uniform, payloads[other])) {
      ++c.visible;
      cur = other;
      has_state = true;
    } else if (has_state) {
      PssStream mutation{&samples[other], &samples[cur], d, &rng};  // the state, mutated
      samples[other].n = 0;
      ++c.mutated;
      if (evaluate(mutation, payloads[other])) {
        ++c.accepted;
        cur = other;
      }
    }
    if (has_state) {
      deposit(payloads[cur]);
      ++c.steps_with_state;
    }
  }
  return true;
}

// The mutation size for the next pass after a pass with acceptance rate `acceptance` (of `mutated`
// proposals), `pass` (0-based) passes adapted so far: a Robbins-Monro step on log d toward
// kTargetAcceptance with gains 1 / sqrt(pass + 1) (Andrieu & Thoms 2008, "A tutorial on adaptive MCMC", on the log scale so that
// d stays positive and moves by factors). Larger d means larger moves and fewer acceptances, so d grows
// when the acceptance is above target. Unchanged when the pass made no proposals.
inline float adapt_mutation_size(float d, double acceptance, uint64_t mutated, int64_t pass) {
  if (mutated == 0) return d;
  double g = 2.0 / std::sqrt(double(pass) + 1.0);
  double nd = double(d) * std::exp(g * (acceptance - double(kTargetAcceptance)));
  return float(std::fmin(double(kMaxMutationSize), std::fmax(double(kMinMutationSize), nd)));
}

// What a driver keeps of the chains between passes: the mutation size the next pass uses, the passes that
// adapted it, the counts over the complete passes. A pass's counts are committed only when the pass
// completes, so a cancelled pass (run again later) leaves no trace.
struct AdaptiveChainState {
  float mutation_size = kInitialMutationSize;
  int64_t adapted_passes = 0;
  ChainCounts totals;
  void commit(const ChainCounts& pass) {
    totals.add(pass);
    const double acceptance = pass.mutated ? double(pass.accepted) / double(pass.mutated) : 0.0;
    mutation_size = adapt_mutation_size(mutation_size, acceptance, pass.mutated, adapted_passes);
    if (pass.mutated) ++adapted_passes;
  }
  AdaptiveSummary summary() const { return summarize_chains(totals, mutation_size); }
};

// Chains per pass for `photons` steps: about 2048 steps each (a chain's start costs it the steps until its
// first visible uniform sample), at most 128 (the parallelism), at least 1.
inline uint32_t adaptive_chain_count(uint64_t photons) {
  uint64_t k = photons / 2048;
  return uint32_t(k < 1 ? 1 : (k > 128 ? 128 : k));
}

}  // namespace caustica
