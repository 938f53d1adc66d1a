// The host side that every CUDA translation unit of the wavefront drivers shares: the scene in device
// memory (DeviceScene) and the renderer that owns the device, that scene and the backend (CudaWavefront).
// Each driver family is instantiated on CudaBackend in its own .cu file (cuda_path.cu, cuda_photon.cu,
// cuda_vcm.cu, cuda_restir.cu), so that they compile in parallel and a change to one driver recompiles
// only its file: ptxas spends most of the build in these instantiations.
#pragma once
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "../../integrator/wavefront_renderers.h"
#include "cuda_backend.cuh"

namespace caustica {

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

// Makes CUDA device `device` current; InputError when there is none such (cuda_render.cu).
int select_cuda_device(int device);

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

}  // namespace caustica
