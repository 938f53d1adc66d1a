// The backend interface (../shared/DESIGN.md, "One source for CPU and GPU"): what a wavefront driver
// (integrator/wavefront_path.h) needs from a machine, and nothing more. A backend B provides
//
//   template <class T> using Buffer = ...;   memory the backend's kernels read and write:
//       Buffer<T>(n), .data(), .size(), .resize(n) (contents undefined after resize)
//   void parallel_for(uint32_t n, F f);      calls f(i) for every i < n, in any order and concurrently;
//                                            f is a CAUSTICA_KERNEL lambda (a __device__ lambda under nvcc)
//   void parallel_for_long(uint32_t n, F f); the same for few items that each run long (spread one per
//                                            CPU task, one per GPU block)
//   uint32_t exclusive_scan(const uint32_t* in, uint32_t* out, uint32_t n);   out[i] = sum in[0..i), returns
//                                            the total; in != out
//   void sort_pairs(K* keys, uint32_t* values, uint32_t n, int key_bits, Buffer<K>& tmp_k,
//                   Buffer<uint32_t>& tmp_v); stable sort of (key, value) pairs by the low key_bits of key
//                                            (K = uint32_t or uint64_t)
//   T reduce(const T* in, uint32_t n, T init, Op op); op an associative CHD functor (min, max, bounds)
//   Tracer tracer() const;                   batch ray queries, per item inside parallel_for:
//                                            tracer.intersect(const Ray&, Hit&), tracer.occluded(const Ray&)
//   void to_host(const Buffer<T>&, T* dst, size_t n); void to_device(Buffer<T>&, const T* src, size_t n)
//   const SceneView& scene() const;          the scene with this backend's pointers
//   void synchronize() const;                returns when all work submitted so far is done (timing)
//
// CPU (backend/cpu/cpu_backend.h): oneTBB and Embree (or the portable BVH). CUDA
// (backend/cuda/cuda_backend.cuh): kernel launches, device memory, CUB, the portable BVH.
// Results never depend on the schedule: every path keeps its own random stream and slot, so the order in
// which a queue is processed (compaction, sorting by material) changes no pixel.
#pragma once
#include "../base/host_device.h"

#if defined(__CUDACC__)
#define CAUSTICA_KERNEL [=] __device__
#else
#define CAUSTICA_KERNEL [=]
#endif
