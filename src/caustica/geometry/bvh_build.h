// Host-side construction of the portable BVH (see bvh.h).
#pragma once
#include <vector>
#include "bvh.h"

namespace caustica {

struct BVH {
  std::vector<BVHNode> nodes;
  std::vector<uint32_t> prim_index;
  BVHView view() const { return {nodes.data(), prim_index.data(), uint32_t(nodes.size())}; }
};

// Builds over primitive bounds; leaves hold at most max_leaf primitives.
BVH build_bvh(const std::vector<Bounds3>& prim_bounds, int max_leaf = 4);

}  // namespace caustica
