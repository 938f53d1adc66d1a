#include "render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <condition_variable>
#include <new>
#include <stdexcept>
#include <thread>

#include "../backend/cpu/cpu_accel.h"
#include "../backend/cuda/cuda_render.h"
#include "../base/error.h"
#include "path.h"
#include "path_lanes.h"
#include "photon_render.h"
#include "upg_render.h"
#include "vcm_render.h"
#include "wavefront_render.h"

namespace caustica {

const std::vector<std::string>& integrator_names() {
  static const std::vector<std::string> names = {"path", "sppm", "ppm", "pppm", "pm",
                                                      "light", "bdpt", "bpm", "vcm", "upg", "restir"};
  return names;
}

namespace {
const char* const kLightSamplerIntegrators[] = {"path", "restir", "pm", "ppm", "sppm", "pppm", "bdpt", "vcm", "upg"};
}

namespace {
const std::pair<const char*, Aov> kAovs[] = {{"depth", Aov::kDepth},         {"position", Aov::kPosition},
                                             {"normal", Aov::kNormal},       {"geo_normal", Aov::kGeoNormal},
                                             {"uv", Aov::kUv},               {"albedo", Aov::kAlbedo}};
}  // namespace

Aov aov_kind(const std::string& name) {
  for (const auto& [n, k] : kAovs)
    if (name == n) return k;
  return Aov::kNone;
}

std::string aov_names() {
  std::string r;
  for (const auto& [n, k] : kAovs) r += (r.empty() ? "" : ", ") + std::string(n);
  return r;
}

bool light_sampler_applies(const std::string& integrator) {
  for (const char* n : kLightSamplerIntegrators)
    if (integrator == n) return true;
  return false;
}

std::string light_sampler_integrators() {
  std::string list;
  for (const char* n : kLightSamplerIntegrators) list += (list.empty() ? "" : ", ") + std::string(n);
  return list;
}

std::string restir_option_expected(const std::string& name, double v) {
  const bool integer = v == std::floor(v);
  if (name == "candidates") return integer && v >= 1 && v <= 1024 ? "" : "an integer in [1, 1024]";
  if (name == "neighbors") return integer && v >= 0 && v <= 32 ? "" : "an integer in [0, 32]";
  if (name == "radius") return v >= 1 && v <= 1e4 ? "" : "a number of pixels in [1, 10000]";
  if (name == "history") return v >= 0 && v <= 1e6 ? "" : "a number in [0, 1000000] (0: no temporal reuse)";
  return "one of candidates, neighbors, radius, history";
}

std::vector<float> Film::image() const {
  std::vector<float> img(size_t(width) * height * 3, 0.f);
  for (size_t i = 0; i < size_t(width) * height; ++i) {
    double w = sum[4 * i + 3];
    if (w > 0)
      for (int c = 0; c < 3; ++c) img[3 * i + c] = float(sum[4 * i + c] / w);
  }
  return img;
}

double Film::noise_relmse() const {
  double acc = 0.0;
  size_t n = 0;
  for (size_t i = 0; i < size_t(width) * height; ++i) {
    double wo = odd[4 * i + 3], we = sum[4 * i + 3] - wo;
    if (wo <= 0.0 || we <= 0.0) continue;
    for (int c = 0; c < 3; ++c) {
      double so = odd[4 * i + c], se = sum[4 * i + c] - so;
      double a = se / we, b = so / wo, m = sum[4 * i + c] / sum[4 * i + 3];
      acc += 0.25 * (a - b) * (a - b) / (m * m + 0.01);
    }
    n += 3;
  }
  return n ? acc / double(n) : -1.0;
}

double relmse(const std::vector<float>& img, const std::vector<float>& ref) {
  double acc = 0.0;
  for (size_t i = 0; i < img.size(); ++i) {
    double d = double(img[i]) - double(ref[i]);
    acc += d * d / (double(ref[i]) * double(ref[i]) + 0.01);
  }
  return img.empty() ? 0.0 : acc / double(img.size());
}

int cuda_device_index(const std::string& d) {
  if (d == "cuda") return 0;
  if (d.rfind("cuda:", 0) == 0 && d.size() > 5 && d.size() <= 8 &&
      d.find_first_not_of("0123456789", 5) == std::string::npos)
    return std::stoi(d.substr(5));
  return -1;
}

bool uses_wavefront(const RenderOptions& o) { return o.wavefront || cuda_device_index(o.device) >= 0; }

void RenderJob::validate(const RenderOptions& o) {
  const auto& names = integrator_names();
  bool known = false;
  std::string list;
  for (const auto& n : names) {
    known |= n == o.integrator;
    list += (list.empty() ? "" : ", ") + n;
  }
  if (!known) throw InputError("unknown integrator '" + o.integrator + "' (allowed: " + list + ")");
  if (o.spp < 0) throw InputError("--spp must be a positive integer, got " + std::to_string(o.spp));
  if (o.time < 0 || !std::isfinite(o.time)) throw InputError("--time must be a positive number of seconds");
  if (o.max_depth < -2 || o.max_depth == 0)
    throw InputError("--max-depth must be a positive integer or -1 (unlimited), got " + std::to_string(o.max_depth));
  if (o.rr_depth < 1) throw InputError("--rr-depth must be a positive integer");
  if (o.threads < 0) throw InputError("--threads must be a positive integer");
  if (o.photons < 0) throw InputError("--photons must be a positive integer");
  if (o.photons > 0x7fffffff && (is_vcm_integrator(o.integrator) || o.integrator == "upg"))
    throw InputError("--photons: at most 2147483647 light subpaths per pass, got " + std::to_string(o.photons));
  if (o.radius < 0 || !std::isfinite(o.radius)) throw InputError("--radius must be a positive number");
  if (!(o.alpha > 0.f && o.alpha < 1.f)) throw InputError("--alpha must be in (0, 1)");
  if (o.pass_offset < 0) throw InputError("--pass-offset must be a non-negative integer");
  if (o.photon_sampling != "uniform" && o.photon_sampling != "adaptive")
    throw InputError("unknown photon sampling '" + o.photon_sampling + "' (allowed: uniform, adaptive)");
  if (o.photon_sampling == "adaptive") {
    if (o.integrator != "ppm" && o.integrator != "sppm" && o.integrator != "pppm")
      throw InputError("--photon-sampling adaptive applies to integrators ppm, sppm and pppm, got '" +
                       o.integrator + "'");
  }
  auto check_restir = [](const char* name, double v, const std::string& shown) {
    std::string expected = restir_option_expected(name, v);
    if (!expected.empty())
      throw InputError(std::string("--restir-") + name + " must be " + expected + ", got " + shown);
  };
  check_restir("candidates", o.restir_candidates, std::to_string(o.restir_candidates));
  check_restir("neighbors", o.restir_neighbors, std::to_string(o.restir_neighbors));
  check_restir("radius", o.restir_radius, std::to_string(o.restir_radius));
  check_restir("history", o.restir_history, std::to_string(o.restir_history));
  {
    const RenderOptions d;
    if (o.integrator != "restir" && (o.restir_candidates != d.restir_candidates ||
                                     o.restir_neighbors != d.restir_neighbors || o.restir_radius != d.restir_radius ||
                                     o.restir_history != d.restir_history))
      throw InputError("--restir-candidates, --restir-neighbors, --restir-radius and --restir-history apply to "
                       "integrator 'restir', got '" + o.integrator + "'");
  }
  if (o.light_sampler != "power" && o.light_sampler != "bvh")
    throw InputError("unknown light sampler '" + o.light_sampler + "' (allowed: power, bvh)");
  if (!o.aov.empty()) {
    if (aov_kind(o.aov) == Aov::kNone)
      throw InputError("unknown AOV '" + o.aov + "' (allowed: " + aov_names() + ")");
    if (o.integrator != "path") throw InputError("--aov applies to integrator 'path', got '" + o.integrator + "'");
  }
  if (o.light_sampler == "bvh" && !light_sampler_applies(o.integrator))
    throw InputError("--light-sampler bvh applies to integrators " + light_sampler_integrators() + ", got '" +
                     o.integrator + "'");
  if (o.accel != "auto" && o.accel != "embree" && o.accel != "small" && o.accel != "bvh")
    throw InputError("unknown accelerator '" + o.accel + "' (allowed: auto, embree, small, bvh)");
  if (o.strategy_images && !is_vcm_integrator(o.integrator))
    throw InputError("--strategy-images needs a bidirectional integrator (allowed: light, bdpt, bpm, vcm), got '" +
                     o.integrator + "'");
  bool cuda = cuda_device_index(o.device) >= 0;
  if (o.device != "cpu" && !cuda)
    throw InputError("unknown device '" + o.device + "' (allowed: cpu, cuda, cuda:N)");
  // Every integrator runs on the wavefront drivers (--wavefront, --device cuda); what does not is refused below
  // and in the photon-sampling check above.
  if (uses_wavefront(o) && o.strategy_images)
    throw InputError("--strategy-images runs on the CPU driver only (not with --wavefront or --device cuda)");
  if (uses_wavefront(o) && is_photon_integrator(o.integrator) && o.photons > 0x7fffffff)
    throw InputError("--photons: at most 2147483647 photon paths per pass on the wavefront, got " +
                     std::to_string(o.photons));
  if (!uses_wavefront(o) || o.integrator != "path") {
    if (!o.compaction) throw InputError("--no-compaction applies to the wavefront path tracer (--wavefront or --device cuda)");
    if (o.sort_materials) throw InputError("--sort-materials applies to the wavefront path tracer (--wavefront or --device cuda)");
    if (o.cache_first_bounce)
      throw InputError("--cache-first-bounce applies to the wavefront path tracer (--wavefront or --device cuda)");
  }
  if (!o.jitter && o.integrator != "path")
    throw InputError("--no-jitter applies to integrator 'path', got '" + o.integrator + "'");
  if (o.cache_first_bounce && o.jitter)
    throw InputError("--cache-first-bounce needs --no-jitter: cached camera-ray hits are valid only when every "
                     "pass traces the same camera rays");
  if (o.target_error < 0 || !std::isfinite(o.target_error)) throw InputError("--target-error must be a positive number");
  if (o.target_error > 0 && o.reference.empty())
    throw InputError("--target-error needs --reference (an image to measure the error against)");
  if (o.target_noise < 0 || !std::isfinite(o.target_noise)) throw InputError("--target-noise must be a positive number");
  if (o.target_noise > 0 && o.integrator != "path")
    throw InputError("--target-noise needs independent passes: integrator 'path' (use --target-error with a "
                     "reference for '" + o.integrator + "')");
}

RenderJob::RenderJob(std::shared_ptr<Scene> scene, RenderOptions opt)
    : scene_(std::move(scene)), opt_(std::move(opt)),
      film_(scene_->view().camera.width, scene_->view().camera.height) {
  validate(opt_);
  if (!opt_.reference.empty() &&
      opt_.reference.size() != size_t(scene_->view().camera.width) * scene_->view().camera.height * 3)
    throw InputError("the reference image is " + std::to_string(opt_.reference.size() / 3) +
                     " pixels, the render " + std::to_string(scene_->view().camera.width) + "x" +
                     std::to_string(scene_->view().camera.height));
  // Participating media and null surfaces: the path tracer and restir (integrator/restir.h), pm, ppm, pppm and
  // sppm (volumetric photon mapping, integrator/pm.h and sppm.h), and light, bdpt, bpm, vcm and upg (medium
  // vertices, volumetric merging, integrator/vcm.h; upg's gathers at surfaces, upg.h), on every driver.
  // Emissive media: path, restir, bdpt, bpm, vcm and upg, whose camera paths score the emission (the others'
  // paths start at lights).
  const bool media_kernels =
      opt_.integrator == "ppm" || opt_.integrator == "pppm" || opt_.integrator == "sppm";  // a volume radius
  const bool media_photons = media_kernels || opt_.integrator == "pm";
  const bool media_bidir = opt_.integrator == "light" || opt_.integrator == "bdpt" || opt_.integrator == "bpm" ||
                           opt_.integrator == "vcm" || opt_.integrator == "upg";
  const bool emissive_ok =
      opt_.integrator == "bdpt" || opt_.integrator == "bpm" || opt_.integrator == "vcm" || opt_.integrator == "upg";
  if (scene_has_media(scene_->view()) && opt_.integrator != "path" && opt_.integrator != "restir") {
    const SceneView& v = scene_->view();
    const std::string what = " (" + std::to_string(v.num_media) + " media in scene '" + scene_->desc().name + "')";
    if (!media_photons && !media_bidir)
      throw InputError("integrator '" + opt_.integrator + "' does not render participating media or null surfaces" +
                       what + "; use --integrator path, restir, bdpt, vcm, bpm, upg, light, pm, ppm, sppm or pppm");
    if (media_bidir && v.num_media > 32767u)  // VcmMergeVertex keeps a medium in 16 bits
      throw InputError("integrator '" + opt_.integrator + "' renders at most 32767 media" + what);
    for (size_t i = 0; i < scene_->desc().media.size() && !emissive_ok; ++i)
      if (medium_emits(scene_->desc().media[i]))
        throw InputError("integrator '" + opt_.integrator + "' does not render emissive media (medium '" +
                         (i < scene_->desc().medium_names.size() ? scene_->desc().medium_names[i] : std::to_string(i)) +
                         "' emits); use --integrator path, restir, bdpt, vcm, bpm or upg");
  }
  if (opt_.volume_radius < 0.f || !std::isfinite(opt_.volume_radius))
    throw InputError("--volume-radius must be a positive number");
  const bool media_merges = opt_.integrator == "bpm" || opt_.integrator == "vcm";
  if (opt_.volume_radius > 0.f && !((media_kernels || media_merges) && scene_has_media(scene_->view())))
    throw InputError("--volume-radius applies to integrators 'ppm', 'pppm', 'sppm', 'bpm' and 'vcm' in scenes "
                     "with participating media");
  // --accel small on a scene it does not take fails here, not in the render thread.
  if (opt_.accel == "small" && cuda_device_index(opt_.device) < 0) (void)cpu_accel();
  bool target = opt_.target_error > 0 || opt_.target_noise > 0;
  if (opt_.spp == 0 && opt_.time == 0.0 && !target) opt_.spp = 16;
  // The buffers of the wavefront drivers (and the CPU photon integrators' per-pixel state) are allocated
  // here, sized by the resolution and the photons / light subpaths per pass: too large a request is an
  // input error naming them, not a crash.
  auto too_large = [&] {
    const SceneView& v = scene_->view();
    return InputError("not enough memory for this render (" + opt_.integrator + " at " +
                      std::to_string(v.camera.width) + "x" + std::to_string(v.camera.height) +
                      (opt_.photons > 0 ? ", --photons " + std::to_string(opt_.photons) : std::string()) + " on " +
                      opt_.device + "): lower --photons or the resolution");
  };
  try {
    make_integrator();
  } catch (const std::bad_alloc&) {
    throw too_large();
  } catch (const std::length_error&) {
    throw too_large();
  }
}

// The integrator's state (buffers sized by the resolution and the photons / light subpaths per pass).
void RenderJob::make_integrator() {
  if (is_photon_integrator(opt_.integrator) && !uses_wavefront(opt_))
    photon_ = std::make_unique<PhotonIntegrator>(scene_, opt_);
  if (is_vcm_integrator(opt_.integrator) && !uses_wavefront(opt_)) vcm_ = std::make_unique<VcmIntegrator>(scene_, opt_);
  if (opt_.integrator == "upg" && !uses_wavefront(opt_)) upg_ = std::make_unique<UpgIntegrator>(scene_, opt_);
  if (uses_wavefront(opt_)) stage_totals_ = std::make_unique<WavefrontPassStats>();
  lanes_ = opt_.lanes && opt_.integrator == "path" && !uses_wavefront(opt_) && path_lanes_available() &&
           path_lanes_supported(scene_->view(), path_params());
  if (opt_.integrator == "restir") {
    // restir has one driver over the backend interface: the CPU backend by default (and with --wavefront),
    // CUDA with --device cuda.
    RestirWavefrontParams p;
    p.pp = path_params();
    p.rp.candidates = uint32_t(opt_.restir_candidates);
    p.rp.neighbors = uint32_t(opt_.restir_neighbors);
    p.rp.radius = opt_.restir_radius;
    p.rp.history = opt_.restir_history;
    int dev = cuda_device_index(opt_.device);
    stage_totals_ = std::make_unique<WavefrontPassStats>();
    wavefront_ = dev >= 0 ? make_cuda_restir_wavefront(scene_, p, dev)
                          : make_cpu_restir_wavefront(scene_, p, opt_.accel == "bvh" ? nullptr : &cpu_accel());
  } else if (uses_wavefront(opt_) && (is_vcm_integrator(opt_.integrator) || opt_.integrator == "upg")) {
    const SceneView& v = scene_->view();
    const uint32_t pixels = uint32_t(v.camera.width) * uint32_t(v.camera.height);
    VcmWavefrontParams p;
    p.base = vcm_pass_params(opt_, vcm_mode(opt_.integrator), path_params().max_depth, 0, pixels);
    if (scene_has_media(scene_->view())) p.base.outer_medium = vcm_outer_medium(*scene_, cpu_accel(), opt_);
    p.light_paths = vcm_light_paths(opt_, pixels);
    p.radius = vcm_initial_radius(*scene_, opt_);
    p.alpha = opt_.alpha;
    if (scene_has_media(v) && (opt_.integrator == "bpm" || opt_.integrator == "vcm"))
      volume_radius_ = p.volume_radius = vcm_initial_volume_radius(*scene_, cpu_accel(), opt_, p.base.mode,
                                                                   p.base.max_depth, p.radius, p.base.outer_medium);
    int dev = cuda_device_index(opt_.device);
    wavefront_ = dev >= 0 ? make_cuda_vcm_wavefront(scene_, p, dev)
                          : make_cpu_vcm_wavefront(scene_, p, opt_.accel == "bvh" ? nullptr : &cpu_accel());
  } else if (uses_wavefront(opt_) && opt_.integrator != "path") {
    PhotonWavefrontParams p;
    p.pppm = opt_.integrator == "pppm";
    p.ppm = opt_.integrator == "ppm";
    p.pm = opt_.integrator == "pm";
    p.k = uint32_t(opt_.k);
    p.seed = opt_.seed;
    p.sampler = opt_.sampler;
    p.max_depth = path_params().max_depth;
    const SceneView& v = scene_->view();
    p.photons = opt_.photons > 0 ? uint32_t(opt_.photons) : uint32_t(v.camera.width) * uint32_t(v.camera.height);
    p.radius = opt_.radius > 0.f ? opt_.radius : automatic_radius(*scene_);
    p.alpha = opt_.alpha;
    p.pass_offset = opt_.pass_offset;
    p.stochastic_hash = opt_.stochastic_hash;
    p.light_bvh = opt_.light_sampler == "bvh";
    p.adaptive = opt_.photon_sampling == "adaptive";
    p.hide_emitters = opt_.hide_emitters;
    p.media = scene_has_media(v);  // pm, ppm, pppm or sppm (validated above)
    p.grid_media = scene_has_grid_media(v);
    if (p.media) {
      p.volume_radius = photon_media_setup(*scene_, cpu_accel(), opt_, p.photons,
                                         p.max_depth == 0xffffffffu ? p.max_depth : p.max_depth - 1, p.radius,
                                         &p.outer_medium);
      volume_radius_ = p.volume_radius;
    }
    int dev = cuda_device_index(opt_.device);
    wavefront_ = dev >= 0 ? make_cuda_photon_wavefront(scene_, p, dev)
                          : make_cpu_photon_wavefront(scene_, p, opt_.accel == "bvh" ? nullptr : &cpu_accel());
  } else if (uses_wavefront(opt_)) {
    if (opt_.cache_first_bounce && scene_->view().camera.aperture_radius > 0.f)
      throw InputError("--cache-first-bounce: the camera has a lens (aperture radius " +
                       std::to_string(scene_->view().camera.aperture_radius) +
                       "), so camera rays differ every pass; use a pinhole camera");
    if (opt_.cache_first_bounce && scene_->view().camera.moving)
      throw InputError("--cache-first-bounce: the camera moves while the shutter is open (motion blur), so camera "
                       "rays differ every pass; use a static camera");
    WavefrontOptions wo;
    wo.compaction = opt_.compaction;
    wo.sort_materials = opt_.sort_materials;
    wo.cache_first_bounce = opt_.cache_first_bounce;
    int dev = cuda_device_index(opt_.device);
    wavefront_ = dev >= 0 ? make_cuda_wavefront(scene_, path_params(), wo, dev)
                          : make_cpu_wavefront(scene_, path_params(), wo, opt_.accel == "bvh" ? nullptr : &cpu_accel());
  }
}

PathParams RenderJob::path_params() const {
  PathParams pp;
  int md = opt_.max_depth == -2 ? scene_->desc().max_depth : opt_.max_depth;
  pp.max_depth = md < 0 ? 0xffffffffu : uint32_t(md);
  pp.rr_depth = uint32_t(opt_.rr_depth);
  pp.seed = opt_.seed;
  pp.sampler = opt_.sampler;
  pp.jitter = opt_.jitter;
  pp.light_bvh = opt_.light_sampler == "bvh";
  pp.hide_emitters = opt_.hide_emitters;
  pp.aov = aov_kind(opt_.aov);
  return pp;
}

Film RenderJob::wavefront_film() const {
  Film f(film_.width, film_.height);
  if (!wavefront_->film(f.sum, f.odd)) throw std::logic_error("wavefront_film: not a path-tracer film");
  return f;
}

const CpuAccel& RenderJob::cpu_accel() const { return scene_->cpu_accel(opt_.accel); }

std::string RenderJob::accel_name() const {
  if (opt_.accel == "bvh") return "bvh";
  if (cuda_device_index(opt_.device) >= 0) return "bvh";  // the GPU traverses the portable BVH
  return cpu_accel().name();
}

std::string RenderJob::device_name() const {
  if (wavefront_) return wavefront_->device_name();
  return opt_.accel == "bvh" ? "cpu (portable BVH)" : "cpu";
}

RenderJob::~RenderJob() {
  cancel();
  if (thread_.joinable()) thread_.join();
}

template <typename Accel>
void RenderJob::render_pass(const Accel& accel, int64_t pass) {
  const SceneView& view = scene_->view();
  const PathParams pp = path_params();
  const int W = film_.width, H = film_.height, T = 16;
  const int tiles_x = (W + T - 1) / T, tiles_y = (H + T - 1) / T;
  tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y, 1), [&](const tbb::blocked_range<int>& r) {
    uint64_t rays = 0, shadow = 0, samples = 0, invalid = 0;
    // One finished camera path into the film; non-finite estimates are dropped and counted.
    auto accumulate = [&](uint32_t pixel, RGB L, float weight) {
      ++samples;
      if (!isfinite3(L)) {
        ++invalid;
        return;
      }
      film_.add(pixel, L, weight, (pass & 1) != 0);
    };
    for (int tile = r.begin(); tile < r.end(); ++tile) {
      if (cancel_.load(std::memory_order_relaxed)) break;
      int x0 = (tile % tiles_x) * T, y0 = (tile / tiles_x) * T;
      if (lanes_) {
        // The tile's paths, eight at a time; every pixel's path is the scalar one, bit for bit.
        const int w = std::min(T, W - x0), h = std::min(T, H - y0);
        LaneResult res[T * T];
        LaneCounts counts;
        path_lanes_trace(view, accel, pp, uint32_t(x0), uint32_t(y0), w, h, uint32_t(pass), res, counts);
        rays += counts.rays;
        shadow += counts.shadow_rays;
        for (int i = 0; i < w * h; ++i) accumulate(res[i].pixel, res[i].L, res[i].weight);
        continue;
      }
      for (int y = y0; y < std::min(y0 + T, H); ++y) {
        for (int x = x0; x < std::min(x0 + T, W); ++x) {
          PathState st;
          path_trace(view, pp, accel, uint32_t(x), uint32_t(y), uint32_t(pass), st, rays, shadow);
          accumulate(st.pixel, st.L, st.weight);
        }
      }
    }
    rays_ += rays;
    shadow_rays_ += shadow;
    samples_ += samples;
    invalid_ += invalid;
  });
}

void RenderJob::run() {
  auto t0 = std::chrono::steady_clock::now();
  // A test hook (tests/python/test_render_failure.py): CAUSTICA_TEST_FAIL_AT_PASS=N makes pass N fail as an
  // out-of-memory or device error would, to check that the passes before it are kept.
  const char* fail_env = std::getenv("CAUSTICA_TEST_FAIL_AT_PASS");
  const int64_t fail_at = fail_env && *fail_env ? std::strtoll(fail_env, nullptr, 10) : -1;
  try {
    int threads = opt_.threads > 0 ? opt_.threads : tbb::this_task_arena::max_concurrency();
    tbb::task_arena arena(threads);
    BVHAccel bvh{&scene_->view()};
    for (int64_t pass = 0;; ++pass) {
      if (opt_.spp > 0 && pass >= opt_.spp) break;
      if (pass == fail_at)
        throw std::runtime_error("pass " + std::to_string(pass) + " failed (CAUSTICA_TEST_FAIL_AT_PASS)");
      double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (opt_.time > 0.0 && elapsed >= opt_.time) break;
      if (cancel_.load()) break;
      // std::mutex is not fair: let a waiting image() snapshot take the film
      // between passes instead of re-locking at once (it could starve for many passes).
      while (snapshot_waiting_.load() > 0) std::this_thread::yield();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        arena.execute([&] {
          if (wavefront_) {
            WavefrontPassStats ps;
            if (!wavefront_->render_pass(uint32_t(pass), &cancel_, ps)) return;
            rays_ += ps.rays;
            shadow_rays_ += ps.shadow_rays;
            invalid_ += ps.invalid;
            photons_ += ps.photons;
            samples_ += uint64_t(film_.width) * film_.height;
            std::lock_guard<std::mutex> stage_lock(stage_mutex_);
            stage_totals_->seconds_visible += ps.seconds_visible;
            stage_totals_->seconds_photons += ps.seconds_photons;
            stage_totals_->seconds_grid += ps.seconds_grid;
            stage_totals_->seconds_gather += ps.seconds_gather;
            stage_totals_->seconds_light += ps.seconds_light;
            stage_totals_->seconds_camera += ps.seconds_camera;
            stage_totals_->seconds_accumulate += ps.seconds_accumulate;
            stage_totals_->stored_photons += ps.stored_photons;
            if (opt_.photon_sampling == "adaptive") {
              std::lock_guard<std::mutex> adaptive_lock(adaptive_mutex_);
              adaptive_ = wavefront_->adaptive_summary();
            }
          } else if (photon_) {
            bool complete = photon_->render_pass(pass, cancel_);
            photons_ = photon_->photons_traced();
            if (!complete) return;
            if (opt_.photon_sampling == "adaptive") {
              std::lock_guard<std::mutex> adaptive_lock(adaptive_mutex_);
              adaptive_ = photon_->adaptive_summary();
            }
            samples_ += uint64_t(film_.width) * film_.height;
          } else if (vcm_) {
            bool complete = vcm_->render_pass(pass, cancel_);
            photons_ = vcm_->photons_traced();
            rays_ = vcm_->rays();
            if (!complete) return;
            samples_ += uint64_t(film_.width) * film_.height;
          } else if (upg_) {
            bool complete = upg_->render_pass(pass, cancel_);
            photons_ = upg_->photons_traced();
            rays_ = upg_->rays();
            if (!complete) return;
            samples_ += uint64_t(film_.width) * film_.height;
          } else if (opt_.accel == "bvh")
            render_pass(bvh, pass);
          else
            render_pass(cpu_accel(), pass);
        });
        // Under the lock, so a snapshot and the pass count (and the pass's end time) always agree.
        if (!cancel_.load()) passes_ = pass + 1;
        seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      }
      if (!cancel_.load() && target_met(pass + 1)) {
        target_reached_ = true;
        break;
      }
    }
  } catch (const std::exception& e) {
    error_ = e.what();
  }
  seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  finished_ = true;
}

void RenderJob::start() {
  thread_ = std::thread([this] { run(); });
}

bool RenderJob::wait(double timeout_seconds) {
  auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_seconds);
  while (!finished_.load()) {
    if (std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (thread_.joinable()) thread_.join();
  if (!error_.empty()) throw std::runtime_error(error_);
  return true;
}

// Checked after each complete pass (the noise estimate after even pass counts,
// when both halves hold the same number of samples); costs O(pixels), small
// next to a pass of O(pixels) paths.
bool RenderJob::target_met(int64_t passes_done) {
  bool met = false;
  if (opt_.target_noise > 0 && passes_done >= 2 && passes_done % 2 == 0) {
    double n;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      n = wavefront_ ? wavefront_film().noise_relmse() : film_.noise_relmse();
    }
    noise_value_ = n;
    met |= n >= 0.0 && n <= opt_.target_noise;
  }
  if (opt_.target_error > 0) {
    double e = relmse(image(), opt_.reference);
    error_value_ = e;
    met |= e <= opt_.target_error;
  }
  return met;
}

RenderStats RenderJob::stats() const {
  RenderStats s;
  s.passes = passes_.load();
  s.target_passes = opt_.spp;
  s.samples = samples_.load();
  s.rays = rays_.load();
  s.shadow_rays = shadow_rays_.load();
  s.invalid_samples = invalid_.load();
  s.seconds = seconds_.load();
  s.photons = photons_.load();
  s.radius = wavefront_ ? wavefront_->initial_radius() : photon_ ? photon_->initial_radius() : vcm_ ? vcm_->initial_radius() : upg_ ? upg_->radius() : 0.f;
  s.volume_radius = photon_ ? photon_->initial_volume_radius()
                    : vcm_  ? vcm_->initial_volume_radius()
                            : volume_radius_;
  if ((photon_ || wavefront_) && opt_.photon_sampling == "adaptive") {
    std::lock_guard<std::mutex> lock(adaptive_mutex_);
    s.adaptive = adaptive_;
  }
  s.done = finished_.load();
  s.cancelled = cancel_.load();
  s.error = error_value_.load();
  s.noise = noise_value_.load();
  s.target_reached = target_reached_.load();
  s.lanes = lanes_ ? kPathLanes : 0;
  if (stage_totals_) {
    std::lock_guard<std::mutex> lock(stage_mutex_);
    s.seconds_visible = stage_totals_->seconds_visible;
    s.seconds_photons = stage_totals_->seconds_photons;
    s.seconds_grid = stage_totals_->seconds_grid;
    s.seconds_gather = stage_totals_->seconds_gather;
    s.seconds_light = stage_totals_->seconds_light;
    s.seconds_camera = stage_totals_->seconds_camera;
    s.seconds_accumulate = stage_totals_->seconds_accumulate;
    s.stored_photons = stage_totals_->stored_photons;
  }
  return s;
}

std::vector<float> RenderJob::image(RenderStats* at_snapshot) const {
  snapshot_waiting_.fetch_add(1);
  std::unique_lock<std::mutex> lock(mutex_);
  snapshot_waiting_.fetch_sub(1);
  // No pass is in flight while the lock is held, so these counters are those of the film copied here.
  if (at_snapshot) *at_snapshot = stats();
  if (photon_) return photon_->image(passes_.load());
  if (vcm_) return vcm_->image(passes_.load());
  if (upg_) return upg_->image(passes_.load());
  if (wavefront_) return wavefront_->image(passes_.load());
  return film_.image();
}

std::vector<std::pair<std::string, std::vector<float>>> RenderJob::strategy_images() const {
  snapshot_waiting_.fetch_add(1);
  std::unique_lock<std::mutex> lock(mutex_);
  snapshot_waiting_.fetch_sub(1);
  if (vcm_) return vcm_->strategy_images(passes_.load());
  return {};
}

}  // namespace caustica
