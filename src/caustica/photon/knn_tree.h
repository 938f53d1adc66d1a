// A portable kd-tree over photons for k-nearest-neighbour queries on every backend: Jensen's photon map
// (Jensen 1996, "Global Illumination using Photon Maps", Sec. 3; Jensen 2001, "Realistic Image Synthesis
// Using Photon Mapping", Ch. 6) in its balanced, pointer-free form: a complete binary tree stored as a heap
// (the children of node i are 2i + 1 and 2i + 2), each node one photon, split at the median along the axis of
// the largest extent of its subtree's photons. Built on the host (build_knn_tree, O(n log n)); queried by
// host/device code through KnnTreeView, with an explicit stack, so that the wavefront drivers on the CPU and
// on CUDA run Jensen's photon mapping (`pm`) from one source. The CPU driver keeps nanoflann (kdtree.h).
//
// The answers are exactly those of PhotonKdTree::knn (checked against it in tests/cpp/test_photon_map.cpp):
// the k smallest (dist2, input index) pairs with dist2 <= max_radius^2, dist2 = photon_dist2, nearest first,
// ties by the lower input index. Pruning is exact: a subtree is skipped only when the squared distance from
// the query to a splitting plane exceeds the current bound, and rounding is monotone, so photon_dist2 of any
// photon beyond the plane is at least that square (all terms are non-negative).
#pragma once
#include <cstdint>
#include <vector>

#include "../base/host_device.h"
#include "../base/math.h"
#include "compact_photon.h"
#include "photon.h"

namespace caustica {

struct KnnTreeView {
  const Photon* photons = nullptr;  // heap order
  const uint32_t* index = nullptr;  // each node's photon's index in the builder's input
  const uint8_t* axis = nullptr;    // each node's splitting axis
  uint32_t n = 0;

  CHD const Photon& photon(uint32_t node) const { return photons[node]; }

  // Up to k nearest photons within max_radius of p: their nodes (photon(node) reads them) and squared
  // distances, nearest first, in out_node[0, count) and out_dist2[0, count); returns count.
  CHD uint32_t knn(Vec3f p, uint32_t k, float max_radius, uint32_t* out_node, float* out_dist2) const {
    if (n == 0 || k == 0 || !(max_radius >= 0.f)) return 0;
    const float max_r2 = max_radius * max_radius;
    uint32_t count = 0;
    struct Entry {
      uint32_t node;
      float bound;  // a lower bound of photon_dist2 from p to every photon of the subtree
    };
    Entry stack[66];
    int sp = 0;
    stack[sp++] = Entry{0u, 0.f};
    while (sp > 0) {
      const Entry e = stack[--sp];
      const float worst = count == k ? out_dist2[k - 1] : max_r2;
      if (e.bound > worst || e.node >= n) continue;
      const Photon& ph = photons[e.node];
      const float d2 = photon_dist2(p, ph.p);
      if (d2 <= max_r2) {
        const uint32_t id = index[e.node];
        auto less = [&](uint32_t j) { return d2 < out_dist2[j] || (d2 == out_dist2[j] && id < index[out_node[j]]); };
        if (count < k || less(k - 1)) {
          uint32_t j = count < k ? count++ : k - 1;
          while (j > 0 && less(j - 1)) {
            out_dist2[j] = out_dist2[j - 1];
            out_node[j] = out_node[j - 1];
            --j;
          }
          out_dist2[j] = d2;
          out_node[j] = e.node;
        }
      }
      const int a = axis[e.node];
      const float diff = p[a] - ph.p[a];
      const uint32_t left = 2 * e.node + 1, right = left + 1;
      const uint32_t near_child = diff <= 0.f ? left : right, far_child = diff <= 0.f ? right : left;
      const float plane = diff * diff;
      if (far_child < n) stack[sp++] = Entry{far_child, plane > e.bound ? plane : e.bound};
      if (near_child < n) stack[sp++] = Entry{near_child, e.bound};
    }
    return count;
  }
};

// The tree's arrays on the host (upload them for a device's view).
struct KnnTreeHost {
  std::vector<Photon> photons;
  std::vector<uint32_t> index;
  std::vector<uint8_t> axis;
  KnnTreeView view() const {
    KnnTreeView v;
    v.photons = photons.data();
    v.index = index.data();
    v.axis = axis.data();
    v.n = uint32_t(photons.size());
    return v;
  }
};

// Builds the tree over photons (at most 2^31 - 1 of them; deterministic: ties at a median are ordered by
// input index).
KnnTreeHost build_knn_tree(const std::vector<Photon>& photons);

}  // namespace caustica
