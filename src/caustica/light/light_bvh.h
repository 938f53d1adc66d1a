// Light selection by a bounding volume hierarchy over the lights (pbrt-v4's BVHLightSampler: Pharr, Jakob &
// Humphreys, "Physically Based Rendering", 4th ed., Sec. 12.6.3, after Conty Estevez & Kulla 2018, "Importance
// Sampling of Many Lights with Adaptive Tree Splitting"). Each node bounds its lights' emitting points (a box),
// the directions of their normals (a cone: axis w, half-angle theta_o), how far beyond a normal they emit
// (theta_e) and their power phi. From a shading point p the importance of a node is
//     phi * cos(theta') / d^2,   theta' = max(0, theta_w - theta_o - theta_b),
// d the distance from p to the box's centre (d^2 at least half the box's diagonal, so that a point inside or
// near a large box does not blow up), theta_w the angle between w and the direction from the centre to p, theta_b the
// half-angle of the cone of directions the box subtends at p; zero when theta' >= theta_e (no light in the node
// can face p). Sampling walks from the root, choosing a child with probability proportional to its importance;
// the probability of a light is the product along its path, recomputed from its bit trail (which child at each
// level) when a BSDF-sampled ray hits it (for MIS). Infinite lights (environment, directional) are chosen
// uniformly with probability n_inf / (n_inf + 1) when the BVH holds lights. Unlike pbrt, the importance omits
// the shading normal's factor: the probability of a light depends on the reference point alone, which is all
// the path tracer keeps of its previous vertex.
#pragma once
#include <cstdint>

#include "../base/math.h"

namespace caustica {

// A node keeps its box as what the importance needs of it: the centre and half the diagonal (the radius of
// the box's bounding sphere), and sin theta_o beside cos theta_o, so that sampling takes three square roots
// per node instead of six (bench/RESULTS.md, "light BVH nodes").
struct LightBvhNode {
  Vec3f c;            // centre of the emitting points' bounding box
  float r = 0.f;      // half its diagonal
  Vec3f w{0, 0, 1};   // axis of the normals' cone
  float cos_o = 1.f;  // cos theta_o: the cone's half-angle
  float sin_o = 0.f;  // sin theta_o
  float cos_e = 0.f;  // cos theta_e: emission beyond a normal (area lights: 90 degrees)
  float phi = 0.f;    // power
  uint32_t child = 0; // interior: the second child (the first follows the node); leaf: the light
  uint32_t flags = 0; // kLeaf, kTwoSided
  static constexpr uint32_t kLeaf = 1, kTwoSided = 2;
};

// Where a light is in the selection: in the BVH (with its bit trail), infinite, or never chosen (no power).
enum : uint32_t { kLightNotSampled = 0, kLightInBvh = 1, kLightInfinite = 2 };

struct LightBvhView {
  const LightBvhNode* nodes = nullptr;
  uint32_t num_nodes = 0;
  const uint64_t* trail = nullptr;   // per light: bit k = the child taken at depth k (1: the second)
  const uint32_t* where = nullptr;   // per light: kLightNotSampled, kLightInBvh, kLightInfinite
  const uint32_t* infinite = nullptr;
  uint32_t num_infinite = 0;

  CHD float p_infinite() const {
    return num_infinite == 0 ? 0.f : float(num_infinite) / float(num_infinite + (num_nodes > 0 ? 1u : 0u));
  }
};

// cos(max(0, a - b)) and sin(max(0, a - b)) from the sines and cosines of a and b (a, b in [0, pi]).
CHD float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
  return cos_a > cos_b ? 1.f : cos_a * cos_b + sin_a * sin_b;
}
CHD float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
  return cos_a > cos_b ? 0.f : sin_a * cos_b - cos_a * sin_b;
}

CHD float light_bvh_importance(const LightBvhNode& b, Vec3f p) {
  if (!(b.phi > 0.f)) return 0.f;
  const Vec3f wi = p - b.c;  // from the centre to p
  const float dc2 = length_sq(wi);
  float d2 = maxf(dc2, b.r);  // pbrt-v4's bound (a length compared with a squared distance, as there)
  if (!(d2 > 0.f)) d2 = 1e-12f;
  // The angle between the cone's axis and the direction from the centre to p.
  const float len = std::sqrt(dc2);
  float cos_w = len > 0.f ? dot(b.w, wi) / len : 1.f;
  if (b.flags & LightBvhNode::kTwoSided) cos_w = std::fabs(cos_w);
  const float sin_w = safe_sqrt(1.f - cos_w * cos_w);
  // The cone of directions from p that the box's bounding sphere subtends: sin theta_b = r / |p - c|.
  const float r2 = b.r * b.r;
  const bool inside = dc2 <= r2;
  const float cos_b = inside ? -1.f : safe_sqrt(1.f - r2 / dc2);
  const float sin_b = inside ? 0.f : minf(b.r / len, 1.f);
  const float cos_x = cos_sub_clamped(sin_w, cos_w, b.sin_o, b.cos_o);
  const float sin_x = sin_sub_clamped(sin_w, cos_w, b.sin_o, b.cos_o);
  const float cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
  if (cos_p <= b.cos_e) return 0.f;
  const float imp = b.phi * cos_p / d2;
  return imp > 0.f && imp < kInf ? imp : 0.f;
}

// Chooses a light for reference point p from u.x (remapped to a fresh uniform number, as
// LightSamplerView::sample_reuse does); its probability in pmf. -1: none can light p.
CHD int32_t light_bvh_sample(const LightBvhView& v, Vec3f p, Vec2f& u, float& pmf) {
  const float p_inf = v.p_infinite();
  float x = u.x;
  if (x < p_inf) {
    float f = x / p_inf * float(v.num_infinite);
    uint32_t i = f >= float(v.num_infinite) ? v.num_infinite - 1 : uint32_t(f);
    u.x = minf(f - float(i), kOneMinusEpsilon);
    pmf = p_inf / float(v.num_infinite);
    return int32_t(v.infinite[i]);
  }
  if (v.num_nodes == 0) return -1;
  x = minf((x - p_inf) / (1.f - p_inf), kOneMinusEpsilon);
  pmf = 1.f - p_inf;
  uint32_t node = 0;
  // An interior root needs no test of its own (its children's importances decide, as in pbrt-v4); a root
  // that is a leaf (one light) is chosen where it can light p.
  if ((v.nodes[0].flags & LightBvhNode::kLeaf) && !(light_bvh_importance(v.nodes[0], p) > 0.f)) return -1;
  while (!(v.nodes[node].flags & LightBvhNode::kLeaf)) {
    const uint32_t c0 = node + 1, c1 = v.nodes[node].child;
    const float i0 = light_bvh_importance(v.nodes[c0], p), i1 = light_bvh_importance(v.nodes[c1], p);
    if (!(i0 + i1 > 0.f)) return -1;
    const float p0 = i0 / (i0 + i1);
    if (x < p0) {
      x = minf(x / p0, kOneMinusEpsilon);
      pmf *= p0;
      node = c0;
    } else {
      x = minf((x - p0) / (1.f - p0), kOneMinusEpsilon);
      pmf *= 1.f - p0;
      node = c1;
    }
  }
  u.x = x;
  return int32_t(v.nodes[node].child);
}

// The probability that light_bvh_sample chooses `light` for reference point p.
CHD float light_bvh_pmf(const LightBvhView& v, Vec3f p, uint32_t light) {
  const uint32_t where = v.where[light];
  if (where == kLightInfinite) return v.p_infinite() / float(v.num_infinite);
  if (where != kLightInBvh) return 0.f;
  if ((v.nodes[0].flags & LightBvhNode::kLeaf) && !(light_bvh_importance(v.nodes[0], p) > 0.f)) return 0.f;
  float pmf = 1.f - v.p_infinite();
  uint64_t trail = v.trail[light];
  uint32_t node = 0;
  while (!(v.nodes[node].flags & LightBvhNode::kLeaf)) {
    const uint32_t c0 = node + 1, c1 = v.nodes[node].child;
    const float i0 = light_bvh_importance(v.nodes[c0], p), i1 = light_bvh_importance(v.nodes[c1], p);
    if (!(i0 + i1 > 0.f)) return 0.f;
    const bool second = (trail & 1u) != 0;
    pmf *= (second ? i1 : i0) / (i0 + i1);
    node = second ? c1 : c0;
    trail >>= 1;
  }
  return pmf;
}

}  // namespace caustica
