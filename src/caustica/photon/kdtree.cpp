// The photon kd-tree on nanoflann (see kdtree.h; Jensen 1996, "Global Illumination using Photon Maps").
#include "kdtree.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <nanoflann.hpp>

#include "compact_photon.h"

namespace caustica {

namespace {

// nanoflann's dataset adaptor: the photon positions, contiguous.
struct PositionCloud {
  std::vector<Vec3f> pos;
  size_t kdtree_get_point_count() const { return pos.size(); }
  float kdtree_get_pt(uint32_t i, size_t dim) const { return pos[i][int(dim)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const { return false; }
};

// The metric: photon_dist2, so that the tree and the tests round alike.
struct PhotonL2 {
  using ElementType = float;
  using DistanceType = float;
  const PositionCloud& cloud;
  explicit PhotonL2(const PositionCloud& c) : cloud(c) {}
  float evalMetric(const float* a, uint32_t i, size_t) const { return photon_dist2(Vec3f(a[0], a[1], a[2]), cloud.pos[i]); }
  template <class U, class V>
  float accum_dist(U a, V b, size_t) const { return (a - b) * (a - b); }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<PhotonL2, PositionCloud, 3, uint32_t>;

// Pruning bound: the true bound plus 1e-4 of it (see kdtree.h), and at least one ulp above it, because
// nanoflann's leaf test is strict (dist < worstDist()): a photon at exactly the bound (a tie with the k-th,
// or a distance of 0 with radius 0) must still reach addPoint. inf stays inf.
inline float pruning_bound(float d2) { return std::nextafter(d2 + d2 * 1e-4f, kInf); }

// Collects every index with dist2 <= r2.
struct RangeResult {
  float r2;
  std::vector<uint32_t>* out;
  size_t size() const { return out->size(); }
  bool full() const { return true; }
  bool addPoint(float d2, uint32_t i) {
    if (d2 <= r2) out->push_back(i);
    return true;
  }
  float worstDist() const { return pruning_bound(r2); }
};

// The k smallest (dist2, index) pairs with dist2 <= max_r2, kept sorted in the caller's arrays.
struct KnnResult {
  uint32_t* idx;
  float* d2s;
  size_t capacity;
  size_t count = 0;
  float max_r2;
  size_t size() const { return count; }
  bool full() const { return count == capacity; }
  static bool less(float da, uint32_t ia, float db, uint32_t ib) { return da < db || (da == db && ia < ib); }
  bool addPoint(float d2, uint32_t i) {
    if (!(d2 <= max_r2)) return true;
    if (count == capacity && !less(d2, i, d2s[count - 1], idx[count - 1])) return true;
    size_t j = count < capacity ? count++ : capacity - 1;
    while (j > 0 && less(d2, i, d2s[j - 1], idx[j - 1])) {
      d2s[j] = d2s[j - 1];
      idx[j] = idx[j - 1];
      --j;
    }
    d2s[j] = d2;
    idx[j] = i;
    return true;
  }
  float worstDist() const { return pruning_bound(count == capacity ? d2s[count - 1] : max_r2); }
};

}  // namespace

struct PhotonKdTree::Impl {
  std::vector<Photon> photons;
  PositionCloud cloud;
  std::unique_ptr<Tree> tree;
  size_t index_bytes = 0;
};

PhotonKdTree::PhotonKdTree() : impl_(std::make_unique<Impl>()) {}
PhotonKdTree::~PhotonKdTree() = default;
PhotonKdTree::PhotonKdTree(PhotonKdTree&&) noexcept = default;
PhotonKdTree& PhotonKdTree::operator=(PhotonKdTree&&) noexcept = default;

void PhotonKdTree::build(const std::vector<Photon>& photons) {
  if (photons.size() >= size_t(UINT32_MAX)) throw std::invalid_argument("PhotonKdTree: more than 2^32 - 2 photons");
  if (!impl_) impl_ = std::make_unique<Impl>();
  impl_->tree.reset();
  impl_->photons = photons;
  impl_->cloud.pos.resize(photons.size());
  for (size_t i = 0; i < photons.size(); ++i) impl_->cloud.pos[i] = photons[i].p;
  impl_->index_bytes = 0;
  if (photons.empty()) return;
  // Leaves of up to 10 photons (nanoflann's default).
  impl_->tree = std::make_unique<Tree>(3, impl_->cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  impl_->index_bytes = impl_->tree->usedMemory(*impl_->tree);
}

size_t PhotonKdTree::knn(Vec3f p, size_t k, float max_radius, uint32_t* out_index, float* out_dist2) const {
  if (!impl_ || !impl_->tree || k == 0 || !(max_radius >= 0.f)) return 0;
  KnnResult res{out_index, out_dist2, k, 0, max_radius * max_radius};
  const float q[3] = {p.x, p.y, p.z};
  impl_->tree->findNeighbors(res, q, nanoflann::SearchParams());
  return res.count;
}

void PhotonKdTree::range(Vec3f p, float radius, std::vector<uint32_t>& out) const {
  out.clear();
  if (!impl_ || !impl_->tree || !(radius >= 0.f)) return;
  RangeResult res{radius * radius, &out};
  const float q[3] = {p.x, p.y, p.z};
  impl_->tree->findNeighbors(res, q, nanoflann::SearchParams());
}

const Photon& PhotonKdTree::photon(uint32_t i) const { return impl_->photons[i]; }

size_t PhotonKdTree::size() const { return impl_ ? impl_->photons.size() : 0; }

size_t PhotonKdTree::bytes() const {
  if (!impl_) return sizeof(*this);
  return sizeof(*this) + sizeof(Impl) + impl_->photons.capacity() * sizeof(Photon) +
         impl_->cloud.pos.capacity() * sizeof(Vec3f) + impl_->index_bytes;
}

}  // namespace caustica
