// The CUDA backend: the backend primitives (CUB scan; sort and reduce are templates in cuda_backend.cuh),
// the scene in device memory, the device list, and the wavefront path tracer, photon integrators and
// bidirectional integrators (integrator/wavefront_path.h, wavefront_photon.h, wavefront_vcm.h)
// instantiated on CudaBackend.
#include <map>

#include "../../base/error.h"
#include "../../integrator/wavefront_renderers.h"
#include "cuda_backend.cuh"
#include "cuda_render.h"

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

namespace {

// The scene's flat arrays copied to device memory, and a SceneView over them (the same struct the CPU
// reads: only the pointers differ).
class DeviceScene {
 public:
  explicit DeviceScene(const Scene& sc) {
    SceneView v = sc.view();
    v.positions = upload(sc.positions);
    v.normals = upload(sc.normals);
    v.uvs = upload(sc.uvs);
    v.colors = upload(sc.colors);
    v.tangents = upload(sc.tangents);
    v.indices = upload(sc.indices);
    v.spheres = upload(sc.spheres);
    v.sphere_frames = upload(sc.sphere_frames);
    v.prim_material = upload(sc.prim_material);
    v.prim_light = upload(sc.prim_light);
    v.materials = upload(sc.materials);
    v.sheen_table = upload(sc.sheen_table);
    v.media = upload(sc.media);
    v.prim_medium = upload(sc.prim_medium);
    v.medium_grids = upload(sc.medium_grids);
    v.grid_values = upload(sc.grid_values);
    v.lights = upload(sc.lights);
    v.light_sampler.prob = upload(sc.alias_prob);
    v.light_sampler.alias = upload(sc.alias_index);
    v.light_sampler.pmf = upload(sc.light_pmf);
    v.light_bvh.nodes = upload(sc.light_bvh_nodes);
    v.light_bvh.trail = upload(sc.light_bvh_trail);
    v.light_bvh.where = upload(sc.light_bvh_where);
    v.light_bvh.infinite = upload(sc.light_bvh_infinite);
    // Texels: one device copy per distinct host array (the environment map shares its texture's).
    std::vector<TextureView> tex = sc.textures;
    for (TextureView& t : tex) t.rgba = texels(t);
    v.textures = upload(tex);
    if (v.envmap.tex.rgba) {
      v.envmap.tex.rgba = texels(v.envmap.tex);
      v.envmap.func = upload(sc.env_func);
      v.envmap.cond_cdf = upload(sc.env_cond_cdf);
      v.envmap.marg_cdf = upload(sc.env_marg_cdf);
      v.envmap.marg_func = upload(sc.env_marg_func);
    }
    v.bvh.nodes = upload(sc.bvh.nodes);
    v.bvh.prim_index = upload(sc.bvh.prim_index);
    view_ = v;
  }
  ~DeviceScene() {
    for (void* p : allocations_) cudaFree(p);
  }
  DeviceScene(const DeviceScene&) = delete;
  DeviceScene& operator=(const DeviceScene&) = delete;
  const SceneView& view() const { return view_; }

 private:
  template <class T>
  const T* upload(const T* src, size_t n) {
    if (n == 0 || !src) return nullptr;
    void* p = nullptr;
    CAUSTICA_CUDA_CHECK(cudaMalloc(&p, sizeof(T) * n));
    allocations_.push_back(p);
    CAUSTICA_CUDA_CHECK(cudaMemcpy(p, src, sizeof(T) * n, cudaMemcpyHostToDevice));
    return static_cast<const T*>(p);
  }
  template <class T>
  const T* upload(const std::vector<T>& v) {
    return upload(v.data(), v.size());
  }
  const float* texels(const TextureView& t) {
    if (!t.rgba) return nullptr;
    auto it = texels_.find(t.rgba);
    if (it != texels_.end()) return it->second;
    const float* d = upload(t.rgba, size_t(t.width) * size_t(t.height) * 4);
    texels_[t.rgba] = d;
    return d;
  }
  SceneView view_;
  std::vector<void*> allocations_;
  std::map<const float*, const float*> texels_;
};

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

// Owns the device (selected, then kept current around every call), the scene in device memory and the
// backend, for the renderer built over them.
class CudaWavefront final : public OwningRenderer {
 public:
  template <class Make>
  CudaWavefront(std::shared_ptr<Scene> scene, int device, Make make)
      : scene_(std::move(scene)), device_(select_cuda_device(device)), dscene_(*scene_), backend_(dscene_.view()) {
    cudaDeviceProp p{};
    CAUSTICA_CUDA_CHECK(cudaGetDeviceProperties(&p, device_));
    inner_ = make(backend_, "cuda:" + std::to_string(device_) + " (" + p.name + ")");
  }
  ~CudaWavefront() override {
    enter();
    inner_.reset();  // before the backend and the scene it refers to
  }

 protected:
  void enter() const override { CAUSTICA_CUDA_CHECK(cudaSetDevice(device_)); }

 private:
  std::shared_ptr<Scene> scene_;
  int device_;
  DeviceScene dscene_;
  CudaBackend backend_;
};

}  // namespace

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

std::unique_ptr<WavefrontRenderer> make_cuda_wavefront(std::shared_ptr<Scene> scene, const PathParams& pp,
                                                       const WavefrontOptions& opt, int device) {
  const uint32_t materials = uint32_t(scene->materials.size());
  return std::make_unique<CudaWavefront>(std::move(scene), device, [&](const CudaBackend& b, std::string name) {
    return std::make_unique<PathWavefrontRenderer<CudaBackend>>(b, std::move(name), pp, opt, materials);
  });
}

std::unique_ptr<WavefrontRenderer> make_cuda_photon_wavefront(std::shared_ptr<Scene> scene,
                                                              const PhotonWavefrontParams& p, int device) {
  return std::make_unique<CudaWavefront>(std::move(scene), device, [&](const CudaBackend& b, std::string name) {
    return std::make_unique<PhotonWavefrontRenderer<CudaBackend>>(b, std::move(name), p);
  });
}

std::unique_ptr<WavefrontRenderer> make_cuda_vcm_wavefront(std::shared_ptr<Scene> scene, const VcmWavefrontParams& p,
                                                           int device) {
  return std::make_unique<CudaWavefront>(std::move(scene), device, [&](const CudaBackend& b, std::string name) {
    return std::make_unique<VcmWavefrontRenderer<CudaBackend>>(b, std::move(name), p);
  });
}

std::unique_ptr<WavefrontRenderer> make_cuda_restir_wavefront(std::shared_ptr<Scene> scene,
                                                              const RestirWavefrontParams& p, int device) {
  return std::make_unique<CudaWavefront>(std::move(scene), device, [&](const CudaBackend& b, std::string name) {
    return std::make_unique<RestirWavefrontRenderer<CudaBackend>>(b, std::move(name), p);
  });
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
