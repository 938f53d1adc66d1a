// Construction of the portable photon kd-tree (knn_tree.h): Jensen's balanced photon map as a complete binary
// tree in heap order, each subtree split at its median along its axis of largest extent.
#include "knn_tree.h"

#include <algorithm>
#include <stdexcept>

namespace caustica {

namespace {

// Nodes in the left subtree of a complete binary tree of m nodes (levels filled left to right).
size_t left_subtree_size(size_t m) {
  if (m <= 1) return 0;
  int h = 0;  // levels below the root that are full: 2^h <= m < 2^(h+1)
  while ((size_t(2) << h) <= m) ++h;
  const size_t full = (size_t(1) << h) - 1;  // nodes of levels 0 .. h-1
  const size_t last = m - full;              // nodes of level h (1 .. 2^h)
  const size_t half = size_t(1) << (h - 1);  // level h's share of the left subtree
  return (full - 1) / 2 + std::min(last, half);
}

struct Builder {
  const std::vector<Photon>& in;
  KnnTreeHost& out;
  std::vector<uint32_t>& items;  // input indices

  void build(size_t begin, size_t end, size_t node) {
    const size_t m = end - begin;
    if (m == 0) return;
    Vec3f lo(kInf, kInf, kInf), hi(-kInf, -kInf, -kInf);
    for (size_t i = begin; i < end; ++i) {
      const Vec3f p = in[items[i]].p;
      lo = Vec3f(std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z));
      hi = Vec3f(std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z));
    }
    const Vec3f ext = hi - lo;
    const int a = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
    const size_t mid = begin + left_subtree_size(m);
    std::nth_element(items.begin() + long(begin), items.begin() + long(mid), items.begin() + long(end),
                     [&](uint32_t x, uint32_t y) {
                       const float px = in[x].p[a], py = in[y].p[a];
                       return px < py || (px == py && x < y);
                     });
    out.photons[node] = in[items[mid]];
    out.index[node] = items[mid];
    out.axis[node] = uint8_t(a);
    build(begin, mid, 2 * node + 1);
    build(mid + 1, end, 2 * node + 2);
  }
};

}  // namespace

KnnTreeHost build_knn_tree(const std::vector<Photon>& photons) {
  if (photons.size() > 0x7fffffffu) throw std::invalid_argument("build_knn_tree: more than 2^31 - 1 photons");
  KnnTreeHost t;
  const size_t n = photons.size();
  t.photons.resize(n);
  t.index.resize(n);
  t.axis.resize(n);
  std::vector<uint32_t> items(n);
  for (size_t i = 0; i < n; ++i) items[i] = uint32_t(i);
  Builder{photons, t, items}.build(0, n, 0);
  return t;
}

}  // namespace caustica
