// The wavefront path tracer (integrator/wavefront_path.h) and the backend primitives it is built on.
// On the CPU backend with Embree it must reproduce the CPU path tracer bit for bit (every path keeps its
// own random stream and slot, so queue order, compaction, sorting and caching change nothing). The CUDA
// backend's tests run where a GPU exists and are skipped, saying why, elsewhere.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <thread>

#include <unistd.h>

#include "caustica/backend/cpu/cpu_backend.h"
#include "caustica/base/sampling.h"
#include "caustica/backend/cuda/cuda_render.h"
#include "caustica/base/error.h"
#include "caustica/integrator/pm.h"
#include "caustica/integrator/render.h"
#include "caustica/integrator/wavefront_render.h"
#include "caustica/scene/builtin/builtin.h"

using namespace caustica;

namespace {

std::shared_ptr<Scene> small_scene(const std::string& name, int w, int h) {
  auto sc = Scene::build(builtin_scene(name));
  sc->set_resolution(w, h);
  return sc;
}

std::vector<float> render(std::shared_ptr<Scene> sc, RenderOptions o, RenderStats* stats = nullptr) {
  RenderJob job(std::move(sc), o);
  job.run();
  if (stats) *stats = job.stats();
  return job.image();
}

void make_job(std::shared_ptr<Scene> sc, const RenderOptions& o) { RenderJob job(std::move(sc), o); }

RenderOptions path_options(int spp, uint64_t seed) {
  RenderOptions o;
  o.integrator = "path";
  o.spp = spp;
  o.seed = seed;
  o.max_depth = 12;
  return o;
}

RenderOptions photon_options(const char* integrator, int passes, uint64_t seed) {
  RenderOptions o;
  o.integrator = integrator;
  o.spp = passes;
  o.seed = seed;
  o.max_depth = 10;
  return o;
}

// Per-region means over seeds: (mean, standard error) of each of R x R blocks of a W x H image.
std::vector<std::pair<double, double>> seeded_region_means(std::shared_ptr<Scene> sc, RenderOptions o, int seeds,
                                                           uint64_t seed0, int R) {
  const int W = sc->view().camera.width, H = sc->view().camera.height;
  std::vector<double> sum(R * R, 0.0), sq(R * R, 0.0);
  for (int k = 0; k < seeds; ++k) {
    o.seed = seed0 + uint64_t(k);
    std::vector<float> img = render(sc, o);
    for (int r = 0; r < R * R; ++r) {
      int rx = r % R, ry = r / R;
      double m = 0.0;
      int cnt = 0;
      for (int y = ry * H / R; y < (ry + 1) * H / R; ++y)
        for (int x = rx * W / R; x < (rx + 1) * W / R; ++x, ++cnt)
          for (int c = 0; c < 3; ++c) m += img[(size_t(y) * W + x) * 3 + c];
      m /= 3.0 * cnt;
      sum[r] += m;
      sq[r] += m * m;
    }
  }
  std::vector<std::pair<double, double>> out;
  for (int r = 0; r < R * R; ++r) {
    double mean = sum[r] / seeds, var = (sq[r] - seeds * mean * mean) / (seeds - 1);
    out.push_back({mean, std::sqrt(std::max(var, 0.0) / seeds)});
  }
  return out;
}

// The render `o` on the CPU wavefront and on the GPU, both over the portable BVH: 4 x 4 region means of 12
// seeds each (independent seeds on the two sides) agree within 4 standard errors of their difference.
void expect_gpu_agrees_per_region(std::shared_ptr<Scene> sc, RenderOptions o, const std::string& what) {
  o.accel = "bvh";
  o.wavefront = true;
  auto cpu = seeded_region_means(sc, o, 12, 100, 4);
  o.device = "cuda";
  auto gpu = seeded_region_means(sc, o, 12, 200, 4);
  for (size_t r = 0; r < cpu.size(); ++r)
    EXPECT_LT(std::fabs(cpu[r].first - gpu[r].first), 4.0 * std::hypot(cpu[r].second, gpu[r].second) + 1e-7)
        << what << " region " << r;
}

}  // namespace

TEST(CpuBackend, ExclusiveScanAndTotal) {
  CpuBackend b(SceneView(), nullptr);
  std::vector<uint32_t> in = {3, 0, 1, 4, 1, 5, 9, 2}, out(in.size());
  uint32_t total = b.exclusive_scan(in.data(), out.data(), uint32_t(in.size()));
  EXPECT_EQ(total, 25u);
  EXPECT_EQ(out, (std::vector<uint32_t>{0, 3, 3, 4, 8, 9, 14, 23}));
  // In place.
  total = b.exclusive_scan(in.data(), in.data(), uint32_t(in.size()));
  EXPECT_EQ(total, 25u);
  EXPECT_EQ(in, out);
}

TEST(CpuBackend, SortPairsIsAStableSortByTheLowKeyBits) {
  CpuBackend b(SceneView(), nullptr);
  for (int bits : {1, 5, 8, 13, 32}) {
    std::vector<uint32_t> keys(5000), values(5000);
    PCG32 rng;
    rng.set_sequence(uint64_t(bits), 7);
    uint32_t mask = bits == 32 ? ~0u : (1u << bits) - 1u;
    for (size_t i = 0; i < keys.size(); ++i) {
      keys[i] = rng.next_u32() & mask;
      values[i] = uint32_t(i);
    }
    std::vector<std::pair<uint32_t, uint32_t>> ref(keys.size());
    for (size_t i = 0; i < keys.size(); ++i) ref[i] = {keys[i], values[i]};
    std::stable_sort(ref.begin(), ref.end(), [](auto& a, auto& c) { return a.first < c.first; });
    CpuBackend::Buffer<uint32_t> tk, tv;
    b.sort_pairs(keys.data(), values.data(), uint32_t(keys.size()), bits, tk, tv);
    for (size_t i = 0; i < keys.size(); ++i) {
      ASSERT_EQ(keys[i], ref[i].first) << bits << " " << i;
      ASSERT_EQ(values[i], ref[i].second) << bits << " " << i;
    }
  }
}

// Bit-identity with the CPU path tracer, for every combination of the wavefront's switches, on scenes with
// diffuse, glossy, mirror and glass materials, area, point and environment lights.
TEST(Wavefront, CpuBackendReproducesThePathTracerBitForBit) {
  for (const char* name : {"cornell", "smallvcm-spheres", "smallvcm-point", "smallvcm-env", "smallvcm-sun", "smallvcm-fog",
                          "smallvcm-smoke"}) {
    auto sc = small_scene(name, 40, 30);
    RenderOptions o = path_options(3, 11);
    RenderStats ref_stats;
    std::vector<float> ref = render(sc, o, &ref_stats);
    double total = 0.0;
    for (float v : ref) total += v;
    ASSERT_GT(total, 0.0) << name;
    for (int mask = 0; mask < 4; ++mask) {
      RenderOptions w = o;
      w.wavefront = true;
      w.compaction = (mask & 1) != 0;
      w.sort_materials = (mask & 2) != 0;
      RenderStats st;
      std::vector<float> img = render(sc, w, &st);
      ASSERT_EQ(img.size(), ref.size());
      size_t diff = 0;
      for (size_t i = 0; i < img.size(); ++i) diff += img[i] != ref[i];
      EXPECT_EQ(diff, 0u) << name << " compaction " << w.compaction << " sort " << w.sort_materials;
      // The same paths: the same numbers of camera/bounce rays and shadow rays as the tile driver counts.
      EXPECT_EQ(st.rays, ref_stats.rays) << name;
      EXPECT_EQ(st.shadow_rays, ref_stats.shadow_rays) << name;
      EXPECT_EQ(st.invalid_samples, ref_stats.invalid_samples) << name;
    }
  }
}

TEST(Wavefront, FirstBounceCacheChangesNothingWithoutJitter) {
  auto sc = small_scene("smallvcm-spheres", 40, 30);
  RenderOptions o = path_options(4, 5);
  o.jitter = false;
  std::vector<float> ref = render(sc, o);
  o.wavefront = true;
  o.cache_first_bounce = true;
  o.sort_materials = true;
  std::vector<float> img = render(sc, o);
  EXPECT_EQ(img, ref);
  // Without jitter every sample of a pixel goes through its centre: a jittered render differs.
  RenderOptions j = path_options(4, 5);
  EXPECT_NE(render(sc, j), ref);
}

TEST(Wavefront, OptionsAreCheckedWithOneLineErrors) {
  auto sc = small_scene("cornell", 8, 8);
  RenderOptions o = path_options(1, 0);
  o.cache_first_bounce = true;
  o.wavefront = true;
  EXPECT_THROW(make_job(sc, o), InputError);  // jitter on
  o = path_options(1, 0);
  o.sort_materials = true;
  EXPECT_THROW(make_job(sc, o), InputError);  // not a wavefront render
  o = path_options(1, 0);
  o.integrator = "pm";
  o.wavefront = true;
  o.k = int(kWavefrontMaxK) + 1;
  EXPECT_THROW(make_job(sc, o), InputError);  // more photons per estimate than the kernels keep
  o.k = int(kWavefrontMaxK);
  EXPECT_NO_THROW(make_job(sc, o));
  o.integrator = "sppm";
  o.sort_materials = true;
  EXPECT_THROW(make_job(sc, o), InputError);  // a path-tracer switch
  o = path_options(1, 0);
  o.device = "gpu";
  EXPECT_THROW(make_job(sc, o), InputError);
  o.device = "cuda:x";
  EXPECT_THROW(make_job(sc, o), InputError);
  EXPECT_EQ(cuda_device_index("cuda"), 0);
  EXPECT_EQ(cuda_device_index("cuda:3"), 3);
  EXPECT_EQ(cuda_device_index("cpu"), -1);
  // A lens makes camera rays differ every pass: no first-bounce cache.
  SceneDesc d = builtin_scene("cornell");
  d.camera.aperture_radius = 0.05f;
  auto lens = Scene::build(d);
  lens->set_resolution(8, 8);
  o = path_options(1, 0);
  o.wavefront = true;
  o.jitter = false;
  o.cache_first_bounce = true;
  EXPECT_THROW(make_job(lens, o), InputError);
}

TEST(Cuda, WithoutAGpuTheDeviceIsAnInputError) {
  std::string why;
  if (!cuda_devices(&why).empty()) GTEST_SKIP() << "a CUDA device is present: the error path is not reachable";
  EXPECT_FALSE(why.empty());
  auto sc = small_scene("cornell", 8, 8);
  RenderOptions o = path_options(1, 0);
  o.device = "cuda";
  EXPECT_THROW(make_job(sc, o), InputError);
}

// On a GPU: the same stage code on the CUDA backend. The portable BVH may differ from Embree in rare
// float ties, and nvcc contracts multiply-adds differently from the host compiler, so the images are not
// bit-identical: compare the CUDA image against the CPU wavefront on the same BVH, per region, within 4
// standard errors measured from independent seeds.
TEST(Cuda, PathTracerMatchesTheCpuPerRegion) {
  std::string why;
  if (cuda_devices(&why).empty()) GTEST_SKIP() << "no CUDA device: " << why;
  for (const char* name : {"cornell", "smallvcm-spheres", "smallvcm-fog", "smallvcm-smoke"}) {
    auto sc = small_scene(name, 32, 32);
    RenderOptions o = path_options(16, 0);
    o.sampler = SamplerType::kIndependent;
    expect_gpu_agrees_per_region(sc, o, name);
  }
}

// On a GPU: the switches change nothing on the GPU either (same device, same arithmetic).
TEST(Cuda, SwitchesChangeNothingOnTheGpu) {
  std::string why;
  if (cuda_devices(&why).empty()) GTEST_SKIP() << "no CUDA device: " << why;
  auto sc = small_scene("smallvcm-spheres", 48, 32);
  RenderOptions o = path_options(3, 9);
  o.device = "cuda";
  o.jitter = false;
  std::vector<float> ref = render(sc, o);
  for (int mask = 1; mask < 8; ++mask) {
    RenderOptions w = o;
    w.compaction = (mask & 1) == 0;
    w.sort_materials = (mask & 2) != 0;
    w.cache_first_bounce = (mask & 4) != 0;
    EXPECT_EQ(render(sc, w), ref) << mask;
  }
}


// sppm, ppm, pppm and pm on the CPU backend run the CPU photon integrator's stage functions; only the order in
// which a visible point adds its photons (in double precision) may differ (pm: the photons are stored in
// another order, so only an exact distance tie could make the k nearest differ), so every pixel agrees to 1e-5
// relative (a single photon changes a pixel by far more: 1e-3 or more of its value at these sizes).
TEST(WavefrontPhoton, CpuBackendMatchesThePhotonIntegrators) {
  for (const char* name : {"cornell", "smallvcm-spheres", "smallvcm-env", "point-in-glass"}) {
    auto sc = small_scene(name, 36, 28);
    for (const char* integrator : {"sppm", "ppm", "pppm", "pm"}) {
      RenderOptions o = photon_options(integrator, 4, 21);
      std::vector<float> ref = render(sc, o);
      double total = 0.0;
      for (float v : ref) total += v;
      ASSERT_GT(total, 0.0) << name;
      o.wavefront = true;
      std::vector<float> img = render(sc, o);
      ASSERT_EQ(img.size(), ref.size());
      for (size_t i = 0; i < img.size(); ++i)
        ASSERT_LE(std::fabs(img[i] - ref[i]), 1e-5f * std::fabs(ref[i]) + 1e-9f)
            << name << " " << integrator << " value " << i;
    }
  }
}

// With stochastic hashing the photon kept in a cell is drawn in another order than on the CPU: the same
// distribution, so the two agree per region within 4 standard errors over independent seeds.
TEST(WavefrontPhoton, StochasticHashingAgreesWithTheCpuPerRegion) {
  auto sc = small_scene("smallvcm-spheres", 24, 24);
  RenderOptions o = photon_options("sppm", 4, 0);
  o.stochastic_hash = true;
  auto cpu = seeded_region_means(sc, o, 16, 500, 3);
  o.wavefront = true;
  auto wf = seeded_region_means(sc, o, 16, 600, 3);
  for (size_t r = 0; r < cpu.size(); ++r)
    EXPECT_LT(std::fabs(cpu[r].first - wf[r].first), 4.0 * std::hypot(cpu[r].second, wf[r].second)) << r;
}

TEST(WavefrontPhoton, CancelledPassChangesNothing) {
  auto sc = small_scene("cornell", 16, 16);
  RenderOptions o = photon_options("sppm", 2, 3);
  o.wavefront = true;
  std::vector<float> two = render(sc, o);
  // A third pass cancelled before it starts leaves the image of two passes.
  auto wf = make_cpu_photon_wavefront(sc, [&] {
    PhotonWavefrontParams p;
    p.seed = 3;
    p.max_depth = 10;
    p.photons = 256;
    p.radius = 0.05f;
    return p;
  }(), &sc->accel());
  std::atomic<bool> cancel{false};
  WavefrontPassStats st;
  ASSERT_TRUE(wf->render_pass(0, &cancel, st));
  ASSERT_TRUE(wf->render_pass(1, &cancel, st));
  std::vector<float> before = wf->image(2);
  cancel = true;
  EXPECT_FALSE(wf->render_pass(2, &cancel, st));
  EXPECT_EQ(wf->image(2), before);
  EXPECT_EQ(two.size(), before.size());
}

// ppm traces its measurement points and pm builds its photon maps in their first complete pass: a first pass
// cancelled (ppm: after the visible points, with the measurement points written; pm: before the photons) and
// run again gives the image of an uncancelled render, and a later cancelled pass changes nothing.
TEST(WavefrontPhoton, CancelledFirstPassOfPpmAndPmChangesNothing) {
  auto sc = small_scene("point-in-glass", 16, 16);
  for (int pm = 0; pm < 2; ++pm) {
    PhotonWavefrontParams p;
    p.ppm = pm == 0;
    p.pm = pm == 1;
    p.seed = 3;
    p.max_depth = 10;
    p.photons = 512;
    p.radius = 0.05f;
    p.k = 20;
    auto ref = make_cpu_photon_wavefront(sc, p, &sc->accel());
    std::atomic<bool> cancel{false};
    WavefrontPassStats st;
    ASSERT_TRUE(ref->render_pass(0, &cancel, st));
    ASSERT_TRUE(ref->render_pass(1, &cancel, st));
    const std::vector<float> two = ref->image(2);
    double total = 0.0;
    for (float v : two) total += v;
    ASSERT_GT(total, 0.0) << pm;

    auto wf = make_cpu_photon_wavefront(sc, p, &sc->accel());
    std::atomic<bool> stop{true};  // the flag is first read after the visible points (ppm), in the photons (pm)
    EXPECT_FALSE(wf->render_pass(0, &stop, st));
    ASSERT_TRUE(wf->render_pass(0, &cancel, st));
    ASSERT_TRUE(wf->render_pass(1, &cancel, st));
    EXPECT_EQ(wf->image(2), two) << pm;
    EXPECT_FALSE(wf->render_pass(2, &stop, st));
    EXPECT_EQ(wf->image(2), two) << pm;
  }
}

// --photon-sampling adaptive on the CPU backend runs the CPU driver's chains (adaptive_photons.h) with the
// same numbers and concatenates their deposits in the same order: the same photons, so images equal the
// CPU driver's to rounding (the grid adds them in another order, as with uniform tracing) and the chains'
// figures (visible fraction, acceptance, next mutation size) are equal. 6000 photon paths per pass: 2
// chains of 3000 steps.
TEST(WavefrontPhoton, AdaptiveTracingMatchesTheCpuDriver) {
  for (const char* name : {"cornell", "point-in-glass", "smallvcm-spheres"}) {
    auto sc = small_scene(name, 24, 20);
    for (const char* integrator : {"sppm", "ppm", "pppm"}) {
      RenderOptions o = photon_options(integrator, 3, 5);
      o.photons = 6000;
      o.photon_sampling = "adaptive";
      RenderStats cpu_stats, wf_stats;
      std::vector<float> ref = render(sc, o, &cpu_stats);
      double total = 0.0;
      for (float v : ref) total += v;
      ASSERT_GT(total, 0.0) << name << " " << integrator;
      ASSERT_GT(cpu_stats.adaptive.acceptance, 0.0) << name << " " << integrator;  // the chains mutated
      o.wavefront = true;
      std::vector<float> img = render(sc, o, &wf_stats);
      ASSERT_EQ(img.size(), ref.size());
      for (size_t i = 0; i < img.size(); ++i)
        ASSERT_LE(std::fabs(img[i] - ref[i]), 1e-5f * std::fabs(ref[i]) + 1e-9f)
            << name << " " << integrator << " value " << i;
      EXPECT_EQ(wf_stats.adaptive.visible, cpu_stats.adaptive.visible) << name << " " << integrator;
      EXPECT_EQ(wf_stats.adaptive.acceptance, cpu_stats.adaptive.acceptance) << name << " " << integrator;
      EXPECT_EQ(wf_stats.adaptive.mutation_size, cpu_stats.adaptive.mutation_size) << name << " " << integrator;
      EXPECT_GT(wf_stats.stored_photons, 0u);
    }
  }
}

// The chains' regions start at one photon per payload and one deposit per chain and grow: every chain runs
// again at each growth, with the same numbers, so the image equals that of the default sizes exactly
// (passes of unlimited depth, where some paths hold many visible photons).
TEST(WavefrontPhoton, AdaptiveRegionsGrowWithoutChangingTheImage) {
  auto sc = small_scene("cornell", 16, 16);
  PhotonWavefrontParams p;
  p.adaptive = true;
  p.seed = 9;
  p.photons = 5000;
  p.radius = 0.08f;
  auto images = [&](uint32_t payload, uint64_t deposits) {
    PhotonWavefrontParams q = p;
    q.adaptive_payload = payload;
    q.adaptive_deposits = deposits;
    auto wf = make_cpu_photon_wavefront(sc, q, &sc->accel());
    std::atomic<bool> cancel{false};
    WavefrontPassStats st;
    for (uint32_t pass = 0; pass < 3; ++pass) EXPECT_TRUE(wf->render_pass(pass, &cancel, st));
    EXPECT_GT(st.stored_photons, 1u);
    return std::make_pair(wf->image(3), wf->adaptive_summary().mutation_size);
  };
  const auto grown = images(1, 1), preset = images(16, 0);
  EXPECT_EQ(grown.first, preset.first);
  EXPECT_EQ(grown.second, preset.second);
  EXPECT_GT(grown.second, 0.0);  // a mutation size: the summary is the chains'
  double total = 0.0;
  for (float v : grown.first) total += v;
  EXPECT_GT(total, 0.0);
}

// A cancel request reaches the chains inside the adaptive stage on the CPU backend (HostCancelFlag), not only
// between stages: a pass cancelled a tenth of the way through returns long before an uncancelled one ends,
// and returns false (the pass leaves nothing behind; AdaptiveChainState commits only completed passes).
// Relative times on the same machine: without the in-chain check the cancelled pass runs to its end (ratio
// ~1); with it, ~0.1 plus the stages before the chains. The bound 0.5 leaves room for scheduling noise.
TEST(WavefrontPhoton, AdaptiveChainsStopWhenCancelled) {
  auto sc = small_scene("cornell", 8, 8);
  PhotonWavefrontParams p;
  p.adaptive = true;
  p.seed = 3;
  p.photons = 1000000;  // 128 chains of ~7800 steps: long enough for their time to dwarf the stages around them
  p.radius = 0.05f;
  auto timed_pass = [&](double cancel_after_s, bool& finished) {
    auto wf = make_cpu_photon_wavefront(sc, p, &sc->accel());
    std::atomic<bool> cancel{false};
    WavefrontPassStats st;
    EXPECT_TRUE(wf->render_pass(0, &cancel, st));  // a first pass: the regions have their size
    const auto t0 = std::chrono::steady_clock::now();
    std::thread stopper;
    if (cancel_after_s > 0.0)
      stopper = std::thread([&] {
        std::this_thread::sleep_for(std::chrono::duration<double>(cancel_after_s));
        cancel = true;
      });
    finished = wf->render_pass(1, &cancel, st);
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (stopper.joinable()) stopper.join();
    return t;
  };
  bool done = false, stopped = true;
  const double full = timed_pass(0.0, done);
  ASSERT_TRUE(done);
  const double cut = timed_pass(0.1 * full, stopped);
  EXPECT_FALSE(stopped);
  EXPECT_LT(cut, 0.5 * full) << "full pass " << full << " s, cancelled pass " << cut << " s";
}

// light, bdpt, bpm, vcm and upg on the CPU backend (integrator/wavefront_vcm.h) run the CPU drivers' stage
// functions in the same order per path, keep light vertices and splats in their path order, build the same
// grid and add each pixel's terms in their order: the images are the CPU drivers' bit for bit. Scenes
// with an area light, a point light inside glass, a sun, an environment, a point light; the box, tent,
// gaussian, mitchell and lanczos filters (splats reach several pixels; the last two with negative weights);
// one light subpath per pixel, fewer (camera path i connects
// to light subpath i mod n) and more; depth limits.
TEST(WavefrontVcm, CpuBackendMatchesTheCpuDriverBitForBit) {
  struct Case {
    const char* scene;
    const char* filter;
    int64_t photons;
    int max_depth;
  };
  const Case cases[] = {{"cornell", "box", 0, 10},
                        {"smallvcm-spheres", "gaussian", 0, -1},
                        {"point-in-glass", "mitchell", 97, 8},
                        {"smallvcm-sun", "tent", 0, 4},
                        {"smallvcm-env", "lanczos", 300, 10},
                        {"smallvcm-point", "box", 2000, -1}};  // more light subpaths than pixels
  for (const Case& c : cases) {
    SceneDesc d = builtin_scene(c.scene);
    d.filter = filter_by_name(c.filter);
    auto sc = Scene::build(d);
    sc->set_resolution(30, 22);
    for (const char* integrator : {"light", "bdpt", "bpm", "vcm", "upg"}) {
      RenderOptions o;
      o.integrator = integrator;
      o.spp = 3;
      o.seed = 17;
      o.max_depth = c.max_depth;
      o.photons = c.photons;
      RenderStats cpu_stats, wf_stats;
      std::vector<float> ref = render(sc, o, &cpu_stats);
      double total = 0.0;
      for (float v : ref) total += v;
      ASSERT_GT(total, 0.0) << c.scene << " " << integrator;
      o.wavefront = true;
      std::vector<float> img = render(sc, o, &wf_stats);
      ASSERT_EQ(img.size(), ref.size());
      size_t differ = 0;
      for (size_t i = 0; i < img.size(); ++i) differ += std::memcmp(&img[i], &ref[i], sizeof(float)) != 0;
      EXPECT_EQ(differ, 0u) << c.scene << " " << integrator;
      EXPECT_EQ(wf_stats.rays, cpu_stats.rays) << c.scene << " " << integrator;
      EXPECT_EQ(wf_stats.photons, cpu_stats.photons) << c.scene << " " << integrator;
      EXPECT_EQ(wf_stats.radius, cpu_stats.radius) << c.scene << " " << integrator;
    }
  }
}

// light, bdpt and vcm in participating media (vcm.h's medium vertices, null surfaces, transmittance on every
// connection, merges at surface vertices only): a homogeneous fog with a point light, a glass lens focusing a
// point light into fog, and a heterogeneous smoke (delta and ratio tracking) - the wavefront reproduces the
// CPU driver bit for bit.
TEST(WavefrontVcm, CpuBackendMatchesTheCpuDriverInMedia) {
  for (const char* name : {"smallvcm-fog", "fog-lens", "smallvcm-smoke"}) {
    auto sc = small_scene(name, 24, 18);
    for (const char* integrator : {"light", "bdpt", "vcm"}) {
      RenderOptions o;
      o.integrator = integrator;
      o.spp = 2;
      o.seed = 23;
      o.max_depth = 12;
      RenderStats cpu_stats, wf_stats;
      std::vector<float> ref = render(sc, o, &cpu_stats);
      double total = 0.0;
      for (float v : ref) total += v;
      ASSERT_GT(total, 0.0) << name << " " << integrator;
      o.wavefront = true;
      std::vector<float> img = render(sc, o, &wf_stats);
      ASSERT_EQ(img.size(), ref.size());
      size_t differ = 0;
      for (size_t i = 0; i < img.size(); ++i) differ += std::memcmp(&img[i], &ref[i], sizeof(float)) != 0;
      EXPECT_EQ(differ, 0u) << name << " " << integrator;
      EXPECT_EQ(wf_stats.rays, cpu_stats.rays) << name << " " << integrator;
    }
  }
}

// The same with the portable BVH (the GPU's traversal) on both sides, and with two threads against one.
TEST(WavefrontVcm, PortableBvhAndThreadCountChangeNothing) {
  auto sc = small_scene("smallvcm-spheres", 26, 18);
  RenderOptions o;
  o.integrator = "vcm";
  o.spp = 2;
  o.seed = 5;
  o.accel = "bvh";
  std::vector<float> ref = render(sc, o);
  o.wavefront = true;
  o.threads = 1;
  std::vector<float> one = render(sc, o);
  o.threads = 2;
  std::vector<float> two = render(sc, o);
  EXPECT_EQ(one, ref);
  EXPECT_EQ(two, ref);
}

TEST(WavefrontVcm, CancelledPassChangesNothing) {
  auto sc = small_scene("smallvcm-spheres", 16, 16);
  VcmWavefrontParams p;
  p.base.mode = VcmMode::kVcm;
  p.base.seed = 3;
  p.base.max_depth = 10;
  p.light_paths = 256;
  p.base.n_light = 256.f;
  p.radius = 0.05f;
  auto wf = make_cpu_vcm_wavefront(sc, p, &sc->accel());
  std::atomic<bool> cancel{false};
  WavefrontPassStats st;
  ASSERT_TRUE(wf->render_pass(0, &cancel, st));
  ASSERT_TRUE(wf->render_pass(1, &cancel, st));
  std::vector<float> before = wf->image(2);
  double total = 0.0;
  for (float v : before) total += v;
  EXPECT_GT(total, 0.0);
  cancel = true;
  EXPECT_FALSE(wf->render_pass(2, &cancel, st));
  EXPECT_EQ(wf->image(2), before);
}

// Too many light subpaths per pass for memory: an input error naming --photons, not a crash. The first
// request is 2e9 path states of 432 bytes (0.86 TB) at once, which Linux refuses on a machine with less
// memory unless it overcommits unconditionally (vm.overcommit_memory = 1: then the allocation could succeed
// and be filled, so the test is skipped, as on machines of 512 GiB or more).
TEST(WavefrontVcm, TooLargeARequestIsAnInputError) {
  FILE* f = std::fopen("/proc/sys/vm/overcommit_memory", "r");
  int mode = -1;
  if (f) {
    if (std::fscanf(f, "%d", &mode) != 1) mode = -1;
    std::fclose(f);
  }
  if (mode != 0 && mode != 2) GTEST_SKIP() << "vm.overcommit_memory is " << mode << ", not 0 or 2";
  const double ram = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGESIZE));
  if (ram >= 512.0 * 1073741824.0) GTEST_SKIP() << "this machine has " << ram / 1073741824.0 << " GiB of memory";
  auto sc = small_scene("cornell", 8, 8);
  for (const char* integrator : {"vcm", "upg"}) {
    RenderOptions o;
    o.integrator = integrator;
    o.wavefront = true;
    o.photons = 2000000000;
    try {
      make_job(sc, o);
      ADD_FAILURE() << integrator << ": no error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("not enough memory for this render"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("--photons 2000000000"), std::string::npos) << e.what();
    }
  }
}

TEST(WavefrontVcm, RefusesWhatOnlyTheCpuDriverDoes) {
  auto sc = small_scene("cornell", 8, 8);
  RenderOptions o;
  o.integrator = "bdpt";
  o.wavefront = true;
  o.strategy_images = true;
  EXPECT_THROW(make_job(sc, o), InputError);
}

// On a GPU: light, bdpt, bpm, vcm and upg agree with the CPU wavefront per region (independent seeds, 4
// standard errors).
TEST(Cuda, BidirectionalMatchesTheCpuPerRegion) {
  std::string why;
  if (cuda_devices(&why).empty()) GTEST_SKIP() << "no CUDA device: " << why;
  auto sc = small_scene("smallvcm-spheres", 32, 32);
  for (const char* integrator : {"light", "bdpt", "bpm", "vcm", "upg"})
    expect_gpu_agrees_per_region(sc, photon_options(integrator, 8, 0), integrator);
  for (const char* name : {"smallvcm-fog", "fog-lens", "smallvcm-smoke"})  // light, bdpt and vcm in media
    for (const char* integrator : {"light", "bdpt", "vcm"})
      expect_gpu_agrees_per_region(small_scene(name, 32, 32), photon_options(integrator, 8, 0),
                                   std::string(integrator) + " " + name);
}

// On a GPU: sppm, ppm, pppm and pm agree with the CPU wavefront per region (independent seeds, 4 standard
// errors; pm's maps are built once per seed), sppm, ppm and pppm also with adaptive photon tracing.
TEST(Cuda, PhotonMappingMatchesTheCpuPerRegion) {
  std::string why;
  if (cuda_devices(&why).empty()) GTEST_SKIP() << "no CUDA device: " << why;
  auto sc = small_scene("smallvcm-spheres", 32, 32);
  for (const char* integrator : {"sppm", "ppm", "pppm", "pm"}) {
    for (bool stochastic : {false, true}) {
      if (stochastic && std::string(integrator) == "pm") continue;  // pm has no hash grid
      RenderOptions o = photon_options(integrator, 8, 0);
      o.stochastic_hash = stochastic;
      expect_gpu_agrees_per_region(sc, o, std::string(integrator) + (stochastic ? " stochastic" : ""));
    }
  }
  for (const char* integrator : {"sppm", "ppm", "pppm"}) {  // adaptive photon tracing (2 chains per pass)
    RenderOptions o = photon_options(integrator, 8, 0);
    o.photons = 4096;
    o.photon_sampling = "adaptive";
    expect_gpu_agrees_per_region(sc, o, std::string(integrator) + " adaptive");
  }
  for (const char* name : {"smallvcm-fog", "fog-lens", "smallvcm-smoke"})  // the photon mappers in media
    for (const char* integrator : {"pppm", "sppm", "pm", "ppm"}) {
      RenderOptions o = photon_options(integrator, 8, 0);
      expect_gpu_agrees_per_region(small_scene(name, 32, 32), o, std::string(integrator) + " " + name);
    }
}

// On a GPU: the portable BVH traversed by the CUDA backend finds the same hits as on the CPU, on random
// rays in every built-in scene (as Accelerators.EmbreeAndPortableBVHAgree checks Embree against it): the
// same hit or miss, the same distance to 1e-4 relative, and where the primitive differs, a tie (the GPU's
// primitive is hit at that distance too). Occlusion agrees except within 0.1% of the hit distance.
TEST(Cuda, BvhHitsMatchTheCpuOnRandomRays) {
  std::string why;
  if (cuda_devices(&why).empty()) GTEST_SKIP() << "no CUDA device: " << why;
  for (const auto& entry : builtin_scenes()) {
    auto sc = Scene::build(builtin_scene(entry.first));
    const SceneView& v = sc->view();
    BVHAccel bvh{&v};
    PCG32 rng(7, 9);
    const int n = 20000;
    std::vector<Ray> rays(n), shadow(n);
    for (int k = 0; k < n; ++k) {
      Vec3f lo = v.bounds.lo, ext = v.bounds.diagonal();
      rays[k].o = lo + Vec3f(rng.next_float() * ext.x, rng.next_float() * ext.y, rng.next_float() * ext.z);
      rays[k].d = square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float()));
      rays[k].tmax = kInf;
    }
    std::vector<Hit> gpu;
    cuda_trace_rays(*sc, rays, false, gpu, 1);
    int mismatches = 0;
    for (int k = 0; k < n; ++k) {
      Hit h;
      bool hit = bvh.intersect(rays[k], h);
      ASSERT_EQ(hit, gpu[k].valid()) << entry.first << " ray " << k;
      shadow[k] = rays[k];
      shadow[k].tmax = hit ? h.t * (k % 2 ? 0.999f : 1.001f) : 1e30f;
      if (!hit) continue;
      EXPECT_NEAR(h.t, gpu[k].t, 1e-4f * std::max(1.f, h.t)) << entry.first;
      if (h.prim != gpu[k].prim) {
        ++mismatches;
        Hit single;
        Ray rr = rays[k];
        ASSERT_TRUE((PrimIntersector{&v, &single}(gpu[k].prim, rr))) << entry.first;
        EXPECT_NEAR(single.t, h.t, 1e-4f * std::max(1.f, h.t)) << entry.first;
      }
    }
    EXPECT_LT(mismatches, n / 100) << entry.first;
    std::vector<Hit> occ;
    cuda_trace_rays(*sc, shadow, true, occ, 1);
    int differ = 0;
    for (int k = 0; k < n; ++k) differ += bvh.occluded(shadow[k]) != occ[k].valid();
    EXPECT_LT(differ, n / 1000) << entry.first;
  }
}
