// A spatial hash grid of photons built by sorting (Hachisuka and Jensen 2010, "Parallel Progressive Photon
// Mapping on GPUs", SIGGRAPH Asia sketch; the construction of their Sec. 2: every photon's grid cell is
// hashed, the (hash, photon) pairs are sorted by hash, and the start of each hash slot's run is recorded).
//
// Layout. The grid has cubic cells of side `cell_size` anchored at the low corner of the photon map's
// bounds. A cell (ix, iy, iz) goes to hash slot mix64(pack(ix, iy, iz)) & (table_size - 1), with
// table_size the smallest power of two >= 2 x the photon count. Photons are stored as 16-byte
// CompactPhotons (compact_photon.h) in slot order, and cell_start[s] .. cell_start[s + 1] is slot s's run
// (table_size + 1 entries). A photon's cell is computed from its *decoded* (quantized) position, so that a
// query finds exactly the photons whose decoded position is within the radius. Memory: 16 bytes per
// photon plus 4 bytes per slot, i.e. 24 to 32 bytes per photon.
//
// Determinism. The build sorts 64-bit keys (slot << 32 | photon index) with tbb::parallel_sort; keys are
// distinct, so the sorted order, and with it every array, is the same for any number of threads.
//
// Query (PhotonGridView::query, CHD). For a query point p and radius r <= cell_size, the cells overlapping
// the box [p - r, p + r] (widened by 1e-5 of a cell against float rounding) are visited: 2 x 2 x 2 cells
// when cell_size >= 2r (the usual choice, cell_size = 2r), up to 3 x 3 x 3 when r is up to cell_size.
// A slot is scanned once even when two visited cells hash to it; photons of other cells that share a slot
// (hash collisions) are rejected by the distance test |p - x|^2 <= r^2 (photon_dist2). Every stored photon
// within r of p is reported exactly once.
//
// Stochastic hashing (build(..., stochastic = true, seed)), the variant of Hachisuka and Jensen 2010 in
// which each hash cell keeps a single photon. Here one photon is kept per occupied *grid cell* (cells that
// collide in a slot keep one each, so power never moves between cells): it is chosen uniformly among the
// n photons of the cell by a deterministic hash of (seed, cell), and its power is multiplied by n, i.e.
// divided by the probability 1/n of keeping it. Properties:
//   - unbiased for the power of each cell: E[n Phi_k] = sum_j Phi_j, and more generally E[n g(photon_k)] =
//     sum_j g(photon_j) for anything g computed from one photon (its direction, its BSDF weight); when all
//     photons of a cell carry equal power the kept power is the cell's total (up to the shared-exponent
//     rounding of compact_photon.h);
//   - biased in position: the cell's power is moved to the kept photon's position, so a density estimate
//     whose disc covers only part of a cell sees all or none of its power. The bias is confined to one
//     cell and vanishes as the cells shrink (with cell_size = 2r it shrinks with the radius, as progressive
//     photon mapping shrinks r);
//   - adds variance: the choice of photon is random (with unequal powers the kept power varies too);
//   - bounds memory to one photon per occupied cell, however many photons are traced: the kept photons
//     are selected first (sorted by (cell, photon index), one chosen per cell) and the table is then built
//     over them alone, 2 to 4 slots per kept photon. The choice is a deterministic function of (seed,
//     photons), whatever the thread count, and keeping one photon per grid cell rather than per hash slot
//     never merges two cells that happen to collide in a slot.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>
#include "../base/host_device.h"
#include "../base/math.h"
#include "../base/rng.h"
#include "../geometry/ray.h"
#include "compact_photon.h"
#include "photon.h"

namespace caustica {

// Cell coordinates are clamped to [-2^20, 2^20 - 1] so that three fit in a 64-bit key (21 bits each).
// Clamping is monotonic, so a photon whose cell lies in a query's cell range stays in the clamped range.
constexpr float kGridCoordLimit = 1048576.f;  // 2^20

CHD int32_t grid_coord(float u) {
  u = u > -kGridCoordLimit ? u : -kGridCoordLimit;  // also maps NaN to the low end
  u = u < kGridCoordLimit - 1.f ? u : kGridCoordLimit - 1.f;
  return int32_t(std::floor(u));
}

CHD uint64_t grid_cell_key(int32_t ix, int32_t iy, int32_t iz) {
  return (uint64_t(uint32_t(ix) & 0x1FFFFFu)) | (uint64_t(uint32_t(iy) & 0x1FFFFFu) << 21) |
         (uint64_t(uint32_t(iz) & 0x1FFFFFu) << 42);
}

CHD uint32_t grid_slot(uint64_t cell_key, uint32_t table_mask) { return uint32_t(mix64(cell_key)) & table_mask; }

// What a kernel needs to query the grid: plain pointers and numbers (device pointers on the GPU).
struct PhotonGridView {
  const CompactPhoton* photons = nullptr;  // num_photons, in slot order
  const uint32_t* cell_start = nullptr;    // table_mask + 2 entries
  uint32_t num_photons = 0;
  uint32_t table_mask = 0;                 // table_size - 1
  float cell_size = 0.f, inv_cell_size = 0.f;
  PhotonQuantizer quant;                   // the grid's origin is quant.lo
  const uint32_t* ids = nullptr;           // with build(..., keep_ids): each record's index in the input

  // The grid cell of a point, as a key (the key the build files a photon under, given its decoded position).
  CHD uint64_t cell_of(Vec3f p) const {
    return grid_cell_key(grid_coord((p.x - quant.lo.x) * inv_cell_size), grid_coord((p.y - quant.lo.y) * inv_cell_size),
                         grid_coord((p.z - quant.lo.z) * inv_cell_size));
  }

  // Calls f(const Photon& decoded) for every stored photon whose decoded position x has
  // photon_dist2(p, x) <= radius^2. Precondition: radius <= cell_size.
  template <class F>
  CHD void query(Vec3f p, float radius, F&& f) const {
    query_indexed(p, radius, [&](uint32_t, const Photon& ph) { f(ph); });
  }

  // The same, calling f(uint32_t id, const Photon& decoded) with the photon's index in the array given to
  // build() when the grid keeps ids (else its position in the grid's own order). Integrators that keep
  // more per photon than the compact record (VCM's light vertices) look it up by this index.
  // `records`/`stride` (optional): an array indexed like the ids f receives, whose entry for each cell
  // run's first photon is prefetched with the photons (for callers that read a record per photon found).
  template <class F>
  CHD void query_indexed(Vec3f p, float radius, F&& f, const void* records = nullptr, uint32_t stride = 0) const {
    visit(p, radius, [&](uint32_t id, const Photon& ph) {
      f(id, ph);
      return false;
    }, records, stride);
  }

  // Whether pred(uint32_t id, const Photon& decoded) is true for some photon within `radius` of p (the
  // photons of query_indexed, in its order, stopping at the first true).
  template <class F>
  CHD bool query_any(Vec3f p, float radius, F&& pred) const {
    return visit(p, radius, pred, nullptr, 0);
  }

 private:
  // query_indexed's traversal; stops and returns true when f returns true.
  template <class F>
  CHD bool visit(Vec3f p, float radius, F&& f, const void* records, uint32_t stride) const {
    if (num_photons == 0) return false;
    const float r2 = radius * radius;
    const float ru = radius * inv_cell_size;
    int32_t c0[3], c1[3];
    for (int a = 0; a < 3; ++a) {
      float u = (p[a] - quant.lo[a]) * inv_cell_size;
      // Widening by 1e-5 cell (relative to the magnitudes involved) covers the float rounding of the cell
      // coordinates of the query and of the photons (a few 2^-24 relative): no photon at distance exactly r
      // is lost to rounding.
      float m = 1e-5f * (std::fabs(u) + ru + 1.f);
      c0[a] = grid_coord(u - ru - m);
      c1[a] = grid_coord(u + ru + m);
      // With radius <= cell_size the range spans at most 4 cells (length 2r/cell_size + 2m <= 2 + 2m).
      if (c1[a] > c0[a] + 3) c1[a] = c0[a] + 3;
    }
    // Two passes: first the slots of all the cells (each once) and their runs, then the photons. The
    // loads of cell_start and of the runs' first records are independent of each other, so their cache
    // misses overlap (the grid is larger than the caches; on the 2-core Xeon of bench/RESULTS.md this
    // raised the query rate by 15% with cells of 2r and 1.9x with cells of r).
    uint32_t run_begin[64], run_end[64];
    int num_runs = 0;
    for (int32_t iz = c0[2]; iz <= c1[2]; ++iz) {
      for (int32_t iy = c0[1]; iy <= c1[1]; ++iy) {
        for (int32_t ix = c0[0]; ix <= c1[0]; ++ix) {
          uint32_t s = grid_slot(grid_cell_key(ix, iy, iz), table_mask);
          bool dup = false;
          for (int k = 0; k < num_runs; ++k) dup = dup || (run_end[k] == s);
          if (dup) continue;
          run_end[num_runs++] = s;  // the slot, for now
        }
      }
    }
    for (int k = 0; k < num_runs; ++k) {
      uint32_t s = run_end[k];
      run_begin[k] = cell_start[s];
      run_end[k] = cell_start[s + 1];
#if !defined(__CUDA_ARCH__) && (defined(__GNUC__) || defined(__clang__))
      __builtin_prefetch(photons + run_begin[k]);
      if (records && run_begin[k] < run_end[k])
        __builtin_prefetch(static_cast<const char*>(records) +
                           size_t(ids ? ids[run_begin[k]] : run_begin[k]) * stride);
#endif
    }
    for (int k = 0; k < num_runs; ++k) {
      for (uint32_t j = run_begin[k]; j < run_end[k]; ++j) {
        const CompactPhoton& c = photons[j];
        Vec3f x = decode_position(c.q, quant);
        if (photon_dist2(p, x) <= r2) {
          Photon ph;
          ph.p = x;
          ph.wi = oct_decode(c.oct);
          ph.power = compact_power(c);
          ph.flags = compact_flags(c);
          if (f(ids ? ids[j] : j, static_cast<const Photon&>(ph))) return true;
        }
      }
    }
    return false;
  }
};

// Free-function form of PhotonGridView::query.
template <class F>
CHD void query(const PhotonGridView& grid, Vec3f p, float radius, F&& f) {
  grid.query(p, radius, static_cast<F&&>(f));
}

// The host-side owner of the arrays.
class PhotonHashGrid {
 public:
  // Builds the grid over `photons`. `bounds` is the scene's box; it is extended by the photons' positions,
  // so photons outside it are never clamped. cell_size > 0 (for queries of radius r, 2r is the usual
  // choice). With `stochastic`, keeps one photon per occupied cell (see the top of this file), chosen by
  // `seed`. Throws std::invalid_argument on a bad cell size or more than 2^32 - 1 photons.
  // With `keep_ids` (not with `stochastic`), the grid also keeps each record's input index (4 bytes per
  // photon) for PhotonGridView::query_indexed.
  void build(const std::vector<Photon>& photons, const Bounds3& bounds, float cell_size, bool stochastic = false,
             uint64_t seed = 0, bool keep_ids = false);

  PhotonGridView view() const;
  size_t size() const { return photons_.size(); }                   // photons stored
  size_t bytes() const;                                             // memory of the arrays and this object
  size_t table_size() const { return cell_start_.empty() ? 0 : cell_start_.size() - 1; }
  const std::vector<CompactPhoton>& photons() const { return photons_; }
  const std::vector<uint32_t>& cell_start() const { return cell_start_; }
  const std::vector<uint32_t>& ids() const { return ids_; }          // with keep_ids: input index per record
  const PhotonQuantizer& quantizer() const { return quant_; }
  float cell_size() const { return cell_size_; }

 private:
  PhotonGridView shape() const;
  void build_sorted(const std::vector<Photon>& photons, bool keep_ids = false);
  std::vector<Photon> select_one_per_cell(const std::vector<Photon>& photons, uint64_t seed) const;

  std::vector<CompactPhoton> photons_;
  std::vector<uint32_t> cell_start_;
  std::vector<uint32_t> ids_;  // input index per record (keep_ids)
  PhotonQuantizer quant_;
  float cell_size_ = 0.f;
};

}  // namespace caustica
