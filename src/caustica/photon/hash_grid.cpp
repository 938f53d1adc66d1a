// Construction of the sorted spatial hash grid (Hachisuka and Jensen 2010, "Parallel Progressive Photon
// Mapping on GPUs"); see hash_grid.h for the layout, the query and the stochastic variant.
#include "hash_grid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

namespace caustica {

namespace {

uint32_t table_size_for(size_t n) {
  // Smallest power of two >= 2n (and >= 1): at most half the slots are occupied.
  uint64_t want = std::max<uint64_t>(1, 2 * uint64_t(n));
  uint64_t t = 1;
  while (t < want) t <<= 1;
  return uint32_t(t);
}

// cell_start[s] = the first position j with slot[j] >= s, for s in [0, table_size]; slots[] is sorted.
// Every s is written by exactly one j, in parallel.
template <class SlotOf>
void fill_cell_start(size_t m, uint32_t table_size, SlotOf slot_of, std::vector<uint32_t>& cell_start) {
  cell_start.assign(size_t(table_size) + 1, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, m + 1, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t j = r.begin(); j != r.end(); ++j) {
      int64_t prev = j == 0 ? -1 : int64_t(slot_of(j - 1));
      int64_t cur = j == m ? int64_t(table_size) : int64_t(slot_of(j));
      for (int64_t s = prev + 1; s <= cur; ++s) cell_start[size_t(s)] = uint32_t(j);
    }
  });
}

struct CellEntry {
  uint64_t cell;
  uint32_t index;
  bool operator<(const CellEntry& o) const { return cell != o.cell ? cell < o.cell : index < o.index; }
};

}  // namespace

void PhotonHashGrid::build(const std::vector<Photon>& photons, const Bounds3& bounds, float cell_size,
                           bool stochastic, uint64_t seed, bool keep_ids) {
  if (!(cell_size > 0.f) || !std::isfinite(cell_size))
    throw std::invalid_argument("PhotonHashGrid: cell_size must be positive and finite, got " +
                                std::to_string(cell_size));
  const size_t n = photons.size();
  if (n >= size_t(UINT32_MAX)) throw std::invalid_argument("PhotonHashGrid: more than 2^32 - 2 photons");

  // Bounds: the scene's, extended by the photons (min/max reductions are exact, so any order gives the same).
  Bounds3 b = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n, 8192), bounds,
      [&](const tbb::blocked_range<size_t>& r, Bounds3 acc) {
        for (size_t i = r.begin(); i != r.end(); ++i) acc.extend(photons[i].p);
        return acc;
      },
      [](Bounds3 a, const Bounds3& c) {
        a.extend(c);
        return a;
      });
  quant_ = make_photon_quantizer(b);
  cell_size_ = cell_size;
  if (stochastic)
    build_sorted(select_one_per_cell(photons, seed));  // same quantizer: the kept photons keep their cells
  else
    build_sorted(photons, keep_ids);
}

// The grid's geometry without its arrays (for cell_of).
PhotonGridView PhotonHashGrid::shape() const {
  PhotonGridView v;
  v.cell_size = cell_size_;
  v.inv_cell_size = 1.f / cell_size_;
  v.quant = quant_;
  return v;
}

void PhotonHashGrid::build_sorted(const std::vector<Photon>& photons, bool keep_ids) {
  const size_t n = photons.size();
  const uint32_t table = table_size_for(n);
  const uint32_t mask = table - 1;
  const PhotonGridView g = shape();
  // Encode, find each photon's cell from its decoded position, and key it by (slot, index).
  std::vector<CompactPhoton> compact(n);
  std::vector<uint64_t> keys(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      compact[i] = encode_photon(photons[i], quant_);
      uint64_t cell = g.cell_of(decode_position(compact[i].q, quant_));
      keys[i] = (uint64_t(grid_slot(cell, mask)) << 32) | uint64_t(i);
    }
  });
  // Distinct keys: the sorted order does not depend on how the sort splits its work.
  tbb::parallel_sort(keys.begin(), keys.end());
  photons_.resize(n);
  photons_.shrink_to_fit();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t j = r.begin(); j != r.end(); ++j) photons_[j] = compact[uint32_t(keys[j])];
  });
  ids_.clear();
  if (keep_ids) {
    ids_.resize(n);
    for (size_t j = 0; j < n; ++j) ids_[j] = uint32_t(keys[j]);
  }
  ids_.shrink_to_fit();
  fill_cell_start(n, table, [&](size_t j) { return uint32_t(keys[j] >> 32); }, cell_start_);
  cell_start_.shrink_to_fit();
}

// Stochastic hashing: the photons sorted by (cell, index), one kept per cell, chosen uniformly by a hash of
// (seed, cell), its power multiplied by the cell's photon count. The result is in cell order.
std::vector<Photon> PhotonHashGrid::select_one_per_cell(const std::vector<Photon>& photons, uint64_t seed) const {
  const size_t n = photons.size();
  const PhotonGridView g = shape();
  std::vector<CellEntry> entries(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      uint16_t q[3];
      encode_position(photons[i].p, quant_, q);
      entries[i] = {g.cell_of(decode_position(q, quant_)), uint32_t(i)};
    }
  });
  // Distinct (cell, index) pairs: a deterministic order.
  tbb::parallel_sort(entries.begin(), entries.end());
  std::vector<uint32_t> group_begin;
  for (size_t j = 0; j < n; ++j)
    if (j == 0 || entries[j].cell != entries[j - 1].cell) group_begin.push_back(uint32_t(j));
  const size_t groups = group_begin.size();
  group_begin.push_back(uint32_t(n));
  std::vector<Photon> kept(groups);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, groups, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t k = r.begin(); k != r.end(); ++k) {
      const uint32_t lo = group_begin[k], count = group_begin[k + 1] - lo;
      // Uniform among the cell's photons (in index order): Lemire's multiply-shift maps 32 hashed bits to
      // [0, count).
      uint32_t bits = uint32_t(hash3(seed, entries[lo].cell, 0x73746f63ULL) >> 32);
      uint32_t pick = uint32_t((uint64_t(bits) * count) >> 32);
      kept[k] = photons[entries[lo + pick].index];
      kept[k].power = kept[k].power * float(count);  // divided by the probability 1/count of keeping it
    }
  });
  return kept;
}

PhotonGridView PhotonHashGrid::view() const {
  PhotonGridView v;
  v.photons = photons_.data();
  v.cell_start = cell_start_.data();
  v.num_photons = uint32_t(photons_.size());
  v.table_mask = cell_start_.empty() ? 0u : uint32_t(cell_start_.size() - 2);
  v.cell_size = cell_size_;
  v.inv_cell_size = cell_size_ > 0.f ? 1.f / cell_size_ : 0.f;
  v.quant = quant_;
  v.ids = ids_.empty() ? nullptr : ids_.data();
  return v;
}

size_t PhotonHashGrid::bytes() const {
  return sizeof(*this) + photons_.capacity() * sizeof(CompactPhoton) + cell_start_.capacity() * sizeof(uint32_t) +
         ids_.capacity() * sizeof(uint32_t);
}

}  // namespace caustica
