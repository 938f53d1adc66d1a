// Binned SAH build (Wald 2007, Sec. 3: 16 bins over the centroid bounds, cost
// C = C_trav + sum_i SA(child_i)/SA(node) * N_i * C_isect with C_trav = 1,
// C_isect = 1). Nodes are stored depth first, left child next to its parent.
#include "bvh_build.h"

#include <algorithm>

namespace caustica {
namespace {

struct Builder {
  const std::vector<Bounds3>& pb;
  std::vector<Vec3f> centroid;
  BVH bvh;
  int max_leaf;

  uint32_t build(uint32_t begin, uint32_t end) {
    uint32_t idx = uint32_t(bvh.nodes.size());
    bvh.nodes.emplace_back();
    Bounds3 b, cb;
    for (uint32_t i = begin; i < end; ++i) {
      b.extend(pb[bvh.prim_index[i]]);
      cb.extend(centroid[bvh.prim_index[i]]);
    }
    bvh.nodes[idx].bounds = b;
    uint32_t n = end - begin;
    auto make_leaf = [&] {
      bvh.nodes[idx].offset = begin;
      bvh.nodes[idx].count = n;
      return idx;
    };
    if (n <= uint32_t(max_leaf)) return make_leaf();
    Vec3f ext = cb.diagonal();
    int axis = ext.x > ext.y ? (ext.x > ext.z ? 0 : 2) : (ext.y > ext.z ? 1 : 2);
    if (ext[axis] <= 0.f) {
      if (n <= 16) return make_leaf();
      uint32_t mid = begin + n / 2;
      return finish(idx, begin, mid, end);
    }
    constexpr int kBins = 16;
    float best_cost = kInf;
    int best_axis = -1, best_split = -1;
    for (int a = 0; a < 3; ++a) {
      if (ext[a] <= 0.f) continue;
      Bounds3 bin_b[kBins];
      uint32_t bin_n[kBins] = {};
      float scale = kBins / ext[a];
      for (uint32_t i = begin; i < end; ++i) {
        uint32_t p = bvh.prim_index[i];
        float t = (centroid[p][a] - cb.lo[a]) * scale;
        int k = t >= 0.f ? std::min(kBins - 1, int(std::min(t, float(kBins)))) : 0;  // NaN -> bin 0
        bin_b[k].extend(pb[p]);
        bin_n[k]++;
      }
      float right_area[kBins];
      uint32_t right_n[kBins];
      Bounds3 acc;
      uint32_t cnt = 0;
      for (int k = kBins - 1; k > 0; --k) {
        acc.extend(bin_b[k]);
        cnt += bin_n[k];
        right_area[k] = acc.surface_area();
        right_n[k] = cnt;
      }
      acc = Bounds3();
      cnt = 0;
      for (int k = 0; k < kBins - 1; ++k) {
        acc.extend(bin_b[k]);
        cnt += bin_n[k];
        if (cnt == 0 || right_n[k + 1] == 0) continue;
        float cost = acc.surface_area() * cnt + right_area[k + 1] * right_n[k + 1];
        if (cost < best_cost) { best_cost = cost; best_axis = a; best_split = k; }
      }
    }
    float leaf_cost = b.surface_area() * float(n);
    float split_cost = b.surface_area() + best_cost;  // C_trav = 1 relative to area
    if (best_axis < 0) return n <= 16 ? make_leaf() : finish(idx, begin, begin + n / 2, end);
    if (split_cost >= leaf_cost && n <= 16) return make_leaf();
    float scale = kBins / ext[best_axis];
    auto it = std::partition(bvh.prim_index.begin() + begin, bvh.prim_index.begin() + end, [&](uint32_t p) {
      int k = std::min(kBins - 1, int((centroid[p][best_axis] - cb.lo[best_axis]) * scale));
      return k <= best_split;
    });
    uint32_t mid = uint32_t(it - bvh.prim_index.begin());
    if (mid == begin || mid == end) mid = begin + n / 2;
    return finish(idx, begin, mid, end);
  }

  uint32_t finish(uint32_t idx, uint32_t begin, uint32_t mid, uint32_t end) {
    build(begin, mid);
    uint32_t right = build(mid, end);
    bvh.nodes[idx].offset = right;
    bvh.nodes[idx].count = 0;
    return idx;
  }
};

}  // namespace

BVH build_bvh(const std::vector<Bounds3>& prim_bounds, int max_leaf) {
  Builder b{prim_bounds, {}, {}, max_leaf};
  b.centroid.resize(prim_bounds.size());
  b.bvh.prim_index.resize(prim_bounds.size());
  for (size_t i = 0; i < prim_bounds.size(); ++i) {
    b.centroid[i] = prim_bounds[i].centroid();
    b.bvh.prim_index[i] = uint32_t(i);
  }
  if (!prim_bounds.empty()) {
    b.bvh.nodes.reserve(2 * prim_bounds.size());
    b.build(0, uint32_t(prim_bounds.size()));
  }
  return std::move(b.bvh);
}

}  // namespace caustica
