// Build time and traversal rate of the portable BVH (geometry/bvh.h: the binned-SAH BVH that the CUDA
// backend traverses, run here on the CPU) against Embree 3 on the same scene, for three kinds of rays:
//   primary  - one camera ray per pixel centre (coherent);
//   diffuse  - from each primary hit, one cosine-distributed direction about the shading normal (incoherent);
//   shadow   - from each primary hit towards a point sampled on a uniformly chosen light other than an
//              environment (any-hit queries; finite tmax except for directional lights).
// The ray sets are generated once (fixed seed) and both accelerators trace exactly the same rays, with 1
// thread and with all threads (tbb::parallel_for over blocks of 1024 rays); each figure is the best of 3.
// Hits are compared too (count of rays whose hit/miss differs), as a sanity check of the comparison.
// Where the scene suits the small-scene test (backend/cpu/small_accel.h: at most 128 triangles and 8 spheres,
// an AVX2 CPU), the same rays go through it too (*_small_mrays; *_small_differ: hit/miss differences from
// Embree). CLUTTER adds that many random triangles (size ~0.15 of the scene, fixed seed) inside the scene's
// bounds, to find the size where the small-scene test stops paying off.
// Where a CUDA device is present (a CUDA build), the same rays are traced there too (*_gpu_mrays: the
// traversal kernel's time, CUDA events, best of 3; *_gpu_differ: hit/miss differences from Embree).
//
// Build: cmake --build build/py --target caustica_bench_bvh   (after `make build`)
// Run:   ./build/py/caustica_bench_bvh SCENE [WIDTH HEIGHT [CLUTTER]]
//        SCENE: a built-in name (cornell, smallvcm-...) or a scene file (e.g. the torus PLY written by
//        `caustica_bench_load generate DIR N`; files without a camera get the default camera and light).
// Prints one JSON line; bench/RESULTS.md rows are written by hand from it.
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "caustica/backend/cpu/cpu_accel.h"
#include "caustica/backend/cuda/cuda_render.h"
#include "caustica/base/error.h"
#include "caustica/base/rng.h"
#include "caustica/base/sampling.h"
#include "caustica/geometry/bvh_build.h"
#include "caustica/light/light_sample.h"
#include "caustica/scene/builtin/builtin.h"
#include "caustica/scene/load.h"
#include "caustica/scene/scene.h"
#include "caustica/scene/shading.h"

using namespace caustica;

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

struct RaySet {
  std::vector<Ray> rays;
  bool shadow = false;
};

// Traces every ray of the set; returns the seconds taken and fills hit flags.
template <typename Accel>
double trace(const Accel& a, const RaySet& set, std::vector<uint8_t>& hit) {
  hit.assign(set.rays.size(), 0);
  double t0 = now();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, set.rays.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      if (set.shadow) {
        hit[i] = a.occluded(set.rays[i]) ? 1 : 0;
      } else {
        Hit h;
        hit[i] = a.intersect(set.rays[i], h) ? 1 : 0;
      }
    }
  });
  return now() - t0;
}

std::vector<Bounds3> primitive_bounds(const Scene& sc) {
  const SceneView& v = sc.view();
  std::vector<Bounds3> pb;
  for (uint32_t t = 0; t < v.num_triangles; ++t) {
    Bounds3 b;
    for (int k = 0; k < 3; ++k) b.extend(v.positions[v.indices[3 * t + k]]);
    pb.push_back(b);
  }
  for (uint32_t i = 0; i < v.num_spheres; ++i) pb.push_back(sphere_bounds(v.spheres[i]));
  return pb;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: caustica_bench_bvh SCENE [WIDTH HEIGHT [CLUTTER]]\n");
    return 2;
  }
  try {
    std::string name = argv[1];
    SceneDesc d = is_builtin_scene(name) ? builtin_scene(name) : load_scene_desc(name);
    if (argc >= 4) {
      d.camera.width = std::atoi(argv[2]);
      d.camera.height = std::atoi(argv[3]);
    }
    const int clutter = argc >= 5 ? std::atoi(argv[4]) : 0;
    if (clutter > 0) {
      std::shared_ptr<Scene> plain = Scene::build(d);
      const Bounds3 b = plain->view().bounds;
      const Vec3f ext = b.diagonal();
      const float size = 0.15f * std::max(ext.x, std::max(ext.y, ext.z));
      MeshDesc m;
      m.name = "clutter";
      PCG32 crng(7, 9);
      for (int i = 0; i < clutter; ++i) {
        Vec3f c = b.lo + Vec3f(crng.next_float() * ext.x, crng.next_float() * ext.y, crng.next_float() * ext.z);
        for (int k = 0; k < 3; ++k) {
          m.positions.push_back(
              c + Vec3f(crng.next_float() - 0.5f, crng.next_float() - 0.5f, crng.next_float() - 0.5f) * size);
          m.indices.push_back(uint32_t(3 * i + k));
        }
      }
      d.meshes.push_back(m);
      ShapeDesc sd;
      sd.name = "clutter";
      sd.mesh = int(d.meshes.size()) - 1;
      d.shapes.push_back(sd);
    }
    std::shared_ptr<Scene> sc = Scene::build(d);
    const SceneView& v = sc->view();
    const int W = v.camera.width, H = v.camera.height;

    // Build times: the portable BVH's binned-SAH build (serial) and Embree's (its own threads).
    std::vector<Bounds3> pb = primitive_bounds(*sc);
    double bvh_build = 1e30, embree_build = 1e30;
    size_t nodes = 0;
    for (int rep = 0; rep < 3; ++rep) {
      double t0 = now();
      BVH b = build_bvh(pb);
      bvh_build = std::min(bvh_build, now() - t0);
      nodes = b.nodes.size();
      t0 = now();
      { CpuAccel e(v, CpuAccel::Kind::kEmbree); }
      embree_build = std::min(embree_build, now() - t0);
    }

    // Ray sets.
    RaySet primary, diffuse, shadow;
    shadow.shadow = true;
    PCG32 rng(12345, 678);
    std::vector<uint32_t> emitters;
    for (uint32_t i = 0; i < v.num_lights; ++i)
      if (v.lights[i].type != LightType::kEnvironment) emitters.push_back(i);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        Ray r = v.camera.generate_ray(Vec2f(x + 0.5f, y + 0.5f), Vec2f(0.5f, 0.5f));
        primary.rays.push_back(r);
        Hit h;
        if (!sc->embree().intersect(r, h)) continue;
        SurfaceHit sh = make_surface_hit(v, r, h);
        Vec3f n = dot(sh.ns, r.d) < 0.f ? sh.ns : -sh.ns;
        Vec3f ng = dot(sh.ng, r.d) < 0.f ? sh.ng : -sh.ng;
        Frame f(n);
        Vec3f w = f.to_world(square_to_cosine_hemisphere(Vec2f(rng.next_float(), rng.next_float())));
        diffuse.rays.push_back(Ray{offset_ray_origin(sh.p, ng, w), w, kInf});
        if (emitters.empty()) continue;
        const Light& l = v.lights[emitters[rng.next_u32() % emitters.size()]];
        LightSample ls;
        Vec3f o = offset_ray_origin(sh.p, ng, -r.d);
        if (!sample_light(v, l, o, Vec2f(rng.next_float(), rng.next_float()), ls)) continue;
        shadow.rays.push_back(std::isfinite(ls.dist) ? spawn_ray_to(o, ls.p_l, ls.n_l) : Ray{o, ls.wi, kInf});
      }

    BVHAccel bvh{&v};
    std::unique_ptr<CpuAccel> small;
    if (CpuAccel::small_suits(v)) small = std::make_unique<CpuAccel>(v, CpuAccel::Kind::kSmall);
    const int all = int(std::thread::hardware_concurrency());
    const std::vector<CudaDeviceInfo> gpus = cuda_devices();
    std::printf("{\"scene\": \"%s\", \"triangles\": %u, \"spheres\": %u, \"width\": %d, \"height\": %d, "
                "\"bvh_nodes\": %zu, \"bvh_build_s\": %.4f, \"embree_build_s\": %.4f, \"clutter\": %d",
                name.c_str(), v.num_triangles, v.num_spheres, W, H, nodes, bvh_build, embree_build, clutter);
    if (!gpus.empty()) std::printf(", \"gpu\": \"%s\"", gpus[0].name.c_str());
    const RaySet* sets[3] = {&primary, &diffuse, &shadow};
    const char* names[3] = {"primary", "diffuse", "shadow"};
    for (int k = 0; k < 3; ++k) {
      const RaySet& set = *sets[k];
      if (set.rays.empty()) continue;
      std::printf(", \"%s_rays\": %zu", names[k], set.rays.size());
      for (int threads : {1, all}) {
        tbb::global_control gc(tbb::global_control::max_allowed_parallelism, size_t(threads));
        double tb = 1e30, te = 1e30, ts = 1e30;
        std::vector<uint8_t> hb, he, hs;
        for (int rep = 0; rep < 3; ++rep) {  // alternating, so that the machine's drift hits all alike
          tb = std::min(tb, trace(bvh, set, hb));
          te = std::min(te, trace(sc->embree(), set, he));
          if (small) ts = std::min(ts, trace(*small, set, hs));
        }
        size_t differ = 0, hits = 0;
        for (size_t i = 0; i < hb.size(); ++i) differ += hb[i] != he[i], hits += he[i];
        if (threads == 1) std::printf(", \"%s_hits\": %zu, \"%s_differ\": %zu", names[k], hits, names[k], differ);
        std::printf(", \"%s_%dt_bvh_mrays\": %.2f, \"%s_%dt_embree_mrays\": %.2f", names[k], threads,
                    double(set.rays.size()) / tb / 1e6, names[k], threads, double(set.rays.size()) / te / 1e6);
        if (small) {
          size_t sdiff = 0;
          for (size_t i = 0; i < hs.size(); ++i) sdiff += hs[i] != he[i];
          if (threads == 1) std::printf(", \"%s_small_differ\": %zu", names[k], sdiff);
          std::printf(", \"%s_%dt_small_mrays\": %.2f", names[k], threads, double(set.rays.size()) / ts / 1e6);
        }
      }
      // The same rays on the GPU (the portable BVH in device memory; kernel time only, best of 3).
      if (!gpus.empty()) {
        std::vector<Hit> gh;
        double tg = cuda_trace_rays(*sc, set.rays, set.shadow, gh, 3);
        std::vector<uint8_t> he;
        trace(sc->embree(), set, he);
        size_t differ = 0;
        for (size_t i = 0; i < gh.size(); ++i) differ += uint8_t(gh[i].valid()) != he[i];
        std::printf(", \"%s_gpu_differ\": %zu, \"%s_gpu_mrays\": %.1f", names[k], differ, names[k],
                    double(set.rays.size()) / tg / 1e6);
      }
    }
    std::printf("}\n");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "caustica_bench_bvh: %s\n", e.what());
    return 2;
  }
}
