// What the rest of caustica sees of the CUDA backend (no CUDA headers here). Built from cuda_render.cu
// when CMake's CAUSTICA_CUDA is ON; otherwise cuda_stub.cpp answers that this build has no CUDA backend.
#pragma once
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "../../integrator/wavefront_render.h"

namespace caustica {

struct CudaDeviceInfo {
  int index = 0;
  std::string name;
  size_t memory = 0;       // bytes of device memory
  int major = 0, minor = 0;  // compute capability
  int multiprocessors = 0;
};

// Whether this build contains the CUDA backend.
bool cuda_built();
// The CUDA devices this process can use; empty without a GPU, a driver or the backend, and then `why`
// (when given) says which, in one line.
std::vector<CudaDeviceInfo> cuda_devices(std::string* why = nullptr);

// The wavefront path tracer on CUDA device `device`: the scene is copied to device memory once. Throws
// InputError when the device does not exist, std::runtime_error on CUDA errors.
std::unique_ptr<WavefrontRenderer> make_cuda_wavefront(std::shared_ptr<Scene> scene, const PathParams& pp,
                                                       const WavefrontOptions& opt, int device);

// sppm / ppm / pppm / pm on CUDA device `device` (integrator/wavefront_photon.h).
std::unique_ptr<WavefrontRenderer> make_cuda_photon_wavefront(std::shared_ptr<Scene> scene,
                                                              const PhotonWavefrontParams& p, int device);

// light / bdpt / bpm / vcm on CUDA device `device` (integrator/wavefront_vcm.h).
std::unique_ptr<WavefrontRenderer> make_cuda_vcm_wavefront(std::shared_ptr<Scene> scene, const VcmWavefrontParams& p,
                                                           int device);

// restir on CUDA device `device` (integrator/wavefront_restir.h).
std::unique_ptr<WavefrontRenderer> make_cuda_restir_wavefront(std::shared_ptr<Scene> scene,
                                                              const RestirWavefrontParams& p, int device);

// Ray queries on CUDA device `device` over the portable BVH, for the accelerator tests and bench_bvh:
// closest hits of `rays` (any_hit false) or occlusion (any_hit true: hits[i].prim != ~0u marks an occluded
// ray), copied back to `hits`. Returns the seconds of one traversal kernel, the best of `repeats` (CUDA
// events; the scene upload and copies are not counted). Throws InputError without a device.
double cuda_trace_rays(const Scene& scene, const std::vector<Ray>& rays, bool any_hit, std::vector<Hit>& hits,
                       int repeats = 3, int device = 0);

}  // namespace caustica
