// A kd-tree over full-precision photons for Jensen's photon mapping on the CPU (Jensen 1996, "Global
// Illumination using Photon Maps"; Jensen 2001, "Realistic Image Synthesis Using Photon Mapping", Ch. 6:
// a balanced kd-tree answering k-nearest-neighbour queries for radiance estimates). The tree is
// nanoflann's KDTreeSingleIndexAdaptor (Debian libnanoflann-dev 1.4.3), behind an opaque pointer so that
// nanoflann stays out of this header; host only.
//
// Semantics (exact, and checked against brute force in tests/cpp/test_photon_map.cpp):
//   - distances are photon_dist2 (compact_photon.h), the same float expression the tests use;
//   - range(p, r) returns every photon i with photon_dist2(p, photons[i].p) <= r^2 (inclusive);
//   - knn(p, k, max_radius) returns the k smallest (dist2, index) pairs with dist2 <= max_radius^2, ordered
//     by dist2 and, among equal distances, by index: ties are broken by the lower index, so the answer is
//     unique and deterministic.
// nanoflann prunes a subtree when its distance bound exceeds the result's current worst distance; the bound
// is accumulated in float along the path and may round up by a few ulps per level, which could drop a photon
// at exactly the boundary. Our result sets therefore report a worst distance 1e-4 (relative) above the
// true one for pruning, far above the rounding (< 2 ulps x depth, depth < 64, i.e. < 1e-5), and filter the
// exact condition themselves.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>
#include "../base/math.h"
#include "photon.h"

namespace caustica {

class PhotonKdTree {
 public:
  PhotonKdTree();
  ~PhotonKdTree();
  PhotonKdTree(PhotonKdTree&&) noexcept;
  PhotonKdTree& operator=(PhotonKdTree&&) noexcept;
  PhotonKdTree(const PhotonKdTree&) = delete;
  PhotonKdTree& operator=(const PhotonKdTree&) = delete;

  // Copies the photons and builds the tree (single-threaded). Indices below are indices into `photons`.
  void build(const std::vector<Photon>& photons);

  // Up to k nearest photons within max_radius of p, nearest first (ties: lower index first); writes their
  // indices and squared distances to out_index[0..count) and out_dist2[0..count), returns count (<= k).
  // max_radius may be kInf.
  size_t knn(Vec3f p, size_t k, float max_radius, uint32_t* out_index, float* out_dist2) const;

  // All photons within radius of p (inclusive), appended to `out` after clearing it, in tree order
  // (deterministic for a given tree; sort the indices if an order is needed).
  void range(Vec3f p, float radius, std::vector<uint32_t>& out) const;

  const Photon& photon(uint32_t i) const;
  size_t size() const;
  // Memory of the photon copy, the position array, nanoflann's index and this object.
  size_t bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace caustica
