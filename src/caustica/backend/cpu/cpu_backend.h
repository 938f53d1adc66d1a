// The CPU backend of the wavefront drivers (backend/backend.h): oneTBB for parallel_for, host memory for
// buffers, Embree (or the portable BVH) for ray queries. It runs the same driver code as the CUDA backend,
// so the GPU's queue logic (compaction, material sorting, first-bounce caching) is tested on every machine.
#pragma once
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstring>
#include <vector>

#include "../../scene/intersect.h"
#include "../backend.h"
#include "cpu_accel.h"

namespace caustica {

class CpuBackend {
 public:
  template <class T>
  class Buffer {
   public:
    Buffer() = default;
    explicit Buffer(size_t n) : v_(n) {}
    void resize(size_t n) { v_.resize(n); }
    T* data() { return v_.data(); }
    const T* data() const { return v_.data(); }
    size_t size() const { return v_.size(); }

   private:
    std::vector<T> v_;
  };

  // Ray queries with Embree (use_bvh = false) or the portable BVH that the GPU traverses.
  struct Tracer {
    const CpuAccel* embree;
    const SceneView* view;
    bool intersect(const Ray& r, Hit& h) const { return embree ? embree->intersect(r, h) : scene_intersect(*view, r, h); }
    bool occluded(const Ray& r) const { return embree ? embree->occluded(r) : scene_occluded(*view, r); }
  };

  CpuBackend(const SceneView& view, const CpuAccel* embree) : view_(view), embree_(embree) {}
  const SceneView& scene() const { return view_; }
  Tracer tracer() const { return Tracer{embree_, &view_}; }
  void synchronize() const {}

  template <class F>
  void parallel_for(uint32_t n, F f) const {
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 256), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t i = r.begin(); i < r.end(); ++i) f(i);
    });
  }
  // Few items that each run long: one item per task, so that they spread over the threads.
  template <class F>
  void parallel_for_long(uint32_t n, F f) const {
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 1), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t i = r.begin(); i < r.end(); ++i) f(i);
    });
  }

  uint32_t exclusive_scan(const uint32_t* in, uint32_t* out, uint32_t n) const {
    uint32_t sum = 0;
    for (uint32_t i = 0; i < n; ++i) {
      uint32_t x = in[i];
      out[i] = sum;
      sum += x;
    }
    return sum;
  }

  // LSD radix sort, 8 bits per pass (stable, as CUB's DeviceRadixSort::SortPairs); 32- or 64-bit keys.
  template <class K>
  void sort_pairs(K* keys, uint32_t* values, uint32_t n, int key_bits, Buffer<K>& tmp_k, Buffer<uint32_t>& tmp_v) const {
    if (tmp_k.size() < n) tmp_k.resize(n);
    if (tmp_v.size() < n) tmp_v.resize(n);
    K *k0 = keys, *k1 = tmp_k.data();
    uint32_t *v0 = values, *v1 = tmp_v.data();
    for (int shift = 0; shift < key_bits; shift += 8) {
      uint32_t count[257] = {};
      for (uint32_t i = 0; i < n; ++i) ++count[uint32_t((k0[i] >> shift) & 0xffu) + 1];
      for (int d = 0; d < 256; ++d) count[d + 1] += count[d];
      for (uint32_t i = 0; i < n; ++i) {
        uint32_t d = uint32_t((k0[i] >> shift) & 0xffu);
        uint32_t j = count[d]++;
        k1[j] = k0[i];
        v1[j] = v0[i];
      }
      std::swap(k0, k1);
      std::swap(v0, v1);
    }
    if (k0 != keys) {
      std::memcpy(keys, k0, sizeof(K) * n);
      std::memcpy(values, v0, sizeof(uint32_t) * n);
    }
  }

  // op(...op(op(init, in[0]), in[1])..., in[n-1]); op associative (the CUDA backend regroups it).
  template <class T, class Op>
  T reduce(const T* in, uint32_t n, T init, Op op) const {
    for (uint32_t i = 0; i < n; ++i) init = op(init, in[i]);
    return init;
  }

  template <class T>
  void to_host(const Buffer<T>& b, T* dst, size_t n) const {
    std::memcpy(static_cast<void*>(dst), b.data(), sizeof(T) * n);
  }
  template <class T>
  void to_device(Buffer<T>& b, const T* src, size_t n) const {
    std::memcpy(static_cast<void*>(b.data()), src, sizeof(T) * n);
  }

 private:
  SceneView view_;
  const CpuAccel* embree_;
};

}  // namespace caustica
