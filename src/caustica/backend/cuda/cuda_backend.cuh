// The CUDA backend of the wavefront drivers (backend/backend.h): explicit device memory (cudaMalloc, never
// managed memory), parallel_for as a kernel launch of a __device__ lambda, prefix sums and sorts through
// CUB, ray queries through the portable BVH (geometry/bvh.h) that the CPU tests against Embree.
// Everything runs on one stream; host reads (to_host, a scan's total) synchronise it.
#pragma once
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/device/device_scan.cuh>
#include <cuda_runtime.h>

#include <cstdint>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>

#include "../../scene/intersect.h"
#include "../backend.h"

namespace caustica {

inline void cuda_check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw std::runtime_error(std::string("CUDA error in ") + what + ": " + cudaGetErrorName(e) + " (" +
                             cudaGetErrorString(e) + ")");
}
#define CAUSTICA_CUDA_CHECK(x) ::caustica::cuda_check((x), #x)

// A typed array in device memory. Movable, not copyable; resize() keeps the allocation when it is large
// enough (contents are undefined after a resize that grows).
template <class T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(size_t n) { resize(n); }
  ~DeviceBuffer() { release(); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& o) noexcept { swap(o); }
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
    swap(o);
    return *this;
  }
  void swap(DeviceBuffer& o) noexcept {
    std::swap(p_, o.p_);
    std::swap(n_, o.n_);
    std::swap(cap_, o.cap_);
  }
  // Throws std::bad_alloc when the device has not enough memory (RenderJob reports that as an input error).
  void resize(size_t n) {
    if (n > cap_) {
      release();
      cudaError_t e = cudaMalloc(reinterpret_cast<void**>(&p_), sizeof(T) * n);
      if (e == cudaErrorMemoryAllocation) {
        cudaGetLastError();  // not sticky: clear it so later calls start clean
        p_ = nullptr;
        throw std::bad_alloc();
      }
      CAUSTICA_CUDA_CHECK(e);
      cap_ = n;
    }
    n_ = n;
  }
  T* data() { return p_; }
  const T* data() const { return p_; }
  size_t size() const { return n_; }
  size_t bytes() const { return sizeof(T) * cap_; }

 private:
  void release() {
    if (p_) cudaFree(p_);
    p_ = nullptr;
    n_ = cap_ = 0;
  }
  T* p_ = nullptr;
  size_t n_ = 0, cap_ = 0;
};

template <class T>
void swap(DeviceBuffer<T>& a, DeviceBuffer<T>& b) noexcept {
  a.swap(b);
}

template <class F>
__global__ void k_parallel_for(uint32_t n, F f) {
  uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

__global__ void k_scan_total(const uint32_t* in, const uint32_t* out, uint32_t n, uint32_t* total);

class CudaBackend {
 public:
  template <class T>
  using Buffer = DeviceBuffer<T>;

  struct Tracer {
    SceneView s;  // device pointers
    CHD bool intersect(const Ray& r, Hit& h) const { return scene_intersect(s, r, h); }
    CHD bool occluded(const Ray& r) const { return scene_occluded(s, r); }
  };

  // `device_view`: the scene with device pointers (DeviceScene::view()).
  explicit CudaBackend(const SceneView& device_view, cudaStream_t stream = nullptr)
      : view_(device_view), stream_(stream), total_(1) {}
  const SceneView& scene() const { return view_; }
  Tracer tracer() const { return Tracer{view_}; }
  cudaStream_t stream() const { return stream_; }
  void synchronize() const { CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_)); }

  template <class F>
  void parallel_for(uint32_t n, F f) const {
    if (n == 0) return;
    constexpr uint32_t kBlock = 256;
    k_parallel_for<<<(n + kBlock - 1) / kBlock, kBlock, 0, stream_>>>(n, f);
    CAUSTICA_CUDA_CHECK(cudaGetLastError());
  }
  // Few items that each run long (adaptive photon tracing's chains): a block of one thread per item, so that
  // they spread over the multiprocessors and no item waits on another's divergent branches in a warp.
  template <class F>
  void parallel_for_long(uint32_t n, F f) const {
    if (n == 0) return;
    k_parallel_for<<<n, 1, 0, stream_>>>(n, f);
    CAUSTICA_CUDA_CHECK(cudaGetLastError());
  }

  // out[i] = in[0] + ... + in[i-1] (CUB DeviceScan::ExclusiveSum); returns the total. in != out.
  uint32_t exclusive_scan(const uint32_t* in, uint32_t* out, uint32_t n) const;

  // Stable sort of (key, value) pairs by the low key_bits (CUB DeviceRadixSort::SortPairs), in place.
  template <class K>
  void sort_pairs(K* keys, uint32_t* values, uint32_t n, int key_bits, Buffer<K>& tmp_k, Buffer<uint32_t>& tmp_v) const {
    if (n <= 1) return;
    if (tmp_k.size() < n) tmp_k.resize(n);
    if (tmp_v.size() < n) tmp_v.resize(n);
    size_t bytes = 0;
    CAUSTICA_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, bytes, keys, tmp_k.data(), values, tmp_v.data(),
                                                        n, 0, key_bits, stream_));
    CAUSTICA_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(temp(bytes), bytes, keys, tmp_k.data(), values,
                                                        tmp_v.data(), n, 0, key_bits, stream_));
    CAUSTICA_CUDA_CHECK(cudaMemcpyAsync(keys, tmp_k.data(), sizeof(K) * n, cudaMemcpyDeviceToDevice, stream_));
    CAUSTICA_CUDA_CHECK(
        cudaMemcpyAsync(values, tmp_v.data(), sizeof(uint32_t) * n, cudaMemcpyDeviceToDevice, stream_));
  }

  // CUB DeviceReduce::Reduce; the result is copied to the host.
  template <class T, class Op>
  T reduce(const T* in, uint32_t n, T init, Op op) const {
    if (n == 0) return init;
    DeviceBuffer<T> out(1);
    size_t bytes = 0;
    CAUSTICA_CUDA_CHECK(cub::DeviceReduce::Reduce(nullptr, bytes, in, out.data(), n, op, init, stream_));
    CAUSTICA_CUDA_CHECK(cub::DeviceReduce::Reduce(temp(bytes), bytes, in, out.data(), n, op, init, stream_));
    T r;
    CAUSTICA_CUDA_CHECK(cudaMemcpyAsync(&r, out.data(), sizeof(T), cudaMemcpyDeviceToHost, stream_));
    CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_));
    return r;
  }

  template <class T>
  void to_host(const Buffer<T>& b, T* dst, size_t n) const {
    CAUSTICA_CUDA_CHECK(cudaMemcpyAsync(dst, b.data(), sizeof(T) * n, cudaMemcpyDeviceToHost, stream_));
    CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_));
  }
  template <class T>
  void to_device(Buffer<T>& b, const T* src, size_t n) const {
    CAUSTICA_CUDA_CHECK(cudaMemcpyAsync(b.data(), src, sizeof(T) * n, cudaMemcpyHostToDevice, stream_));
    CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_));
  }

 private:
  void* temp(size_t bytes) const;
  SceneView view_;
  cudaStream_t stream_;
  mutable DeviceBuffer<uint8_t> temp_;
  mutable DeviceBuffer<uint32_t> total_;
};

}  // namespace caustica
