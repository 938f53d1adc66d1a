// The CUDA backend: the backend primitives (CUB scan; sort and reduce are templates in cuda_backend.cuh),
// the device list and selection, and the ray queries of the hit-parity test and bench_bvh. The wavefront
// drivers are instantiated on CudaBackend in cuda_path.cu, cuda_photon.cu, cuda_vcm.cu and cuda_restir.cu.
#include "../../base/error.h"
#include "cuda_render.h"
#include "cuda_wavefront.cuh"

namespace caustica {

__global__ void k_scan_total(const uint32_t* in, const uint32_t* out, uint32_t n, uint32_t* total) {
  *total = out[n - 1] + in[n - 1];
}

void* CudaBackend::temp(size_t bytes) const {
  // Never null: CUB reads a null temporary buffer as "only report the size" and would skip the work.
  if (bytes < 256) bytes = 256;
  if (temp_.size() < bytes) temp_.resize(bytes);
  return temp_.data();
}

uint32_t CudaBackend::exclusive_scan(const uint32_t* in, uint32_t* out, uint32_t n) const {
  if (n == 0) return 0;
  size_t bytes = 0;
  CAUSTICA_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(nullptr, bytes, in, out, n, stream_));
  CAUSTICA_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(temp(bytes), bytes, in, out, n, stream_));
  k_scan_total<<<1, 1, 0, stream_>>>(in, out, n, total_.data());
  CAUSTICA_CUDA_CHECK(cudaGetLastError());
  uint32_t t = 0;
  CAUSTICA_CUDA_CHECK(cudaMemcpyAsync(&t, total_.data(), sizeof(uint32_t), cudaMemcpyDeviceToHost, stream_));
  CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_));
  return t;
}

// Makes CUDA device `device` current; InputError when there is none such.
int select_cuda_device(int device) {
  std::string why;
  std::vector<CudaDeviceInfo> list = cuda_devices(&why);
  if (list.empty()) throw InputError("device 'cuda' is not available: " + why);
  if (device < 0 || device >= int(list.size()))
    throw InputError("device 'cuda:" + std::to_string(device) + "' does not exist (this machine has " +
                     std::to_string(list.size()) + " CUDA device(s))");
  CAUSTICA_CUDA_CHECK(cudaSetDevice(device));
  return device;
}

bool cuda_built() { return true; }

std::vector<CudaDeviceInfo> cuda_devices(std::string* why) {
  int n = 0;
  cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) {
    if (why) {
      if (e == cudaErrorInsufficientDriver)
        *why = "no NVIDIA driver for CUDA 13.0 (none installed, or older than release 580)";
      else if (e == cudaErrorNoDevice)
        *why = "no CUDA device found";
      else
        *why = std::string("no usable CUDA device (") + cudaGetErrorString(e) + ")";
    }
    cudaGetLastError();  // clear the sticky-free error so later calls start clean
    return {};
  }
  std::vector<CudaDeviceInfo> out;
  for (int i = 0; i < n; ++i) {
    cudaDeviceProp p{};
    if (cudaGetDeviceProperties(&p, i) != cudaSuccess) continue;
    CudaDeviceInfo d;
    d.index = i;
    d.name = p.name;
    d.memory = p.totalGlobalMem;
    d.major = p.major;
    d.minor = p.minor;
    d.multiprocessors = p.multiProcessorCount;
    out.push_back(d);
  }
  if (out.empty() && why) *why = "no CUDA device found";
  return out;
}

double cuda_trace_rays(const Scene& scene, const std::vector<Ray>& rays, bool any_hit, std::vector<Hit>& hits,
                       int repeats, int device) {
  select_cuda_device(device);
  DeviceScene ds(scene);
  CudaBackend b(ds.view());
  const uint32_t n = uint32_t(rays.size());
  DeviceBuffer<Ray> d_rays(n);
  DeviceBuffer<Hit> d_hits(n);
  b.to_device(d_rays, rays.data(), n);
  const Ray* r = d_rays.data();
  Hit* h = d_hits.data();
  const CudaBackend::Tracer tracer = b.tracer();
  cudaEvent_t start, stop;
  CAUSTICA_CUDA_CHECK(cudaEventCreate(&start));
  CAUSTICA_CUDA_CHECK(cudaEventCreate(&stop));
  float best = 1e30f;
  for (int rep = 0; rep < (repeats > 0 ? repeats : 1); ++rep) {
    CAUSTICA_CUDA_CHECK(cudaEventRecord(start, b.stream()));
    if (any_hit) {
      b.parallel_for(n, CAUSTICA_KERNEL(uint32_t i) {
        Hit x;
        if (tracer.occluded(r[i])) x.prim = 0;
        h[i] = x;
      });
    } else {
      b.parallel_for(n, CAUSTICA_KERNEL(uint32_t i) { tracer.intersect(r[i], h[i]); });
    }
    CAUSTICA_CUDA_CHECK(cudaEventRecord(stop, b.stream()));
    CAUSTICA_CUDA_CHECK(cudaEventSynchronize(stop));
    float ms = 0.f;
    CAUSTICA_CUDA_CHECK(cudaEventElapsedTime(&ms, start, stop));
    best = ms < best ? ms : best;
  }
  cudaEventDestroy(start);
  cudaEventDestroy(stop);
  hits.resize(n);
  b.to_host(d_hits, hits.data(), n);
  return double(best) * 1e-3;
}

}  // namespace caustica
