#include "photon_render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "../base/error.h"
#include "../base/sampler.h"
#include "../light/light_sample.h"
#include "../material/bsdf.h"
#include "../photon/adaptive.h"
#include "../photon/hash_grid.h"
#include "../photon/trace.h"
#include "adaptive_photons.h"
#include "path.h"
#include "pm.h"

namespace caustica {

bool is_photon_integrator(const std::string& n) { return n == "ppm" || n == "sppm" || n == "pppm" || n == "pm"; }

float automatic_radius(const Scene& scene) {
  const SceneView& v = scene.view();
  const int W = v.camera.width, H = v.camera.height;
  std::vector<float> fp;
  const float pixel_angle = 2.f * v.camera.tan_half_y / float(H);
  for (int y = 0; y < H; y += std::max(1, H / 32))
    for (int x = 0; x < W; x += std::max(1, W / 32)) {
      Ray r = v.camera.generate_ray(Vec2f(x + 0.5f, y + 0.5f), Vec2f(0.5f, 0.5f));
      Hit h;
      // A pixel's footprint at the hit: distance x pixel angle, or the pixel's own size (orthographic).
      // (The distance from the lens: a near clipping plane moves the ray's origin.)
      if (scene.accel().intersect(r, h))
        fp.push_back(v.camera.orthographic ? pixel_angle : (h.t + v.camera.near_distance(r.d)) * pixel_angle);
    }
  if (fp.empty()) return 1e-3f * v.bsphere_radius;
  std::nth_element(fp.begin(), fp.begin() + fp.size() / 2, fp.end());
  return 2.f * fp[fp.size() / 2];
}

float automatic_volume_radius(const Scene& scene, const CpuAccel& accel, uint64_t seed, uint64_t photons,
                              uint32_t max_depth, int32_t outside) {
  constexpr uint32_t kVolumeRadiusPass = 0xffffffeu;  // a pass index no render pass uses
  std::vector<Photon> volume;
  for (const Photon& ph : PhotonIntegrator::trace_photons(scene.view(), accel, seed, kVolumeRadiusPass, photons,
                                                          max_depth, false, nullptr, outside))
    if (ph.flags & kPhotonVolume) volume.push_back(ph);
  if (volume.size() <= size_t(kVolumeRadiusK)) return 0.f;
  PhotonKdTree tree;
  tree.build(volume);
  const size_t probes = std::min<size_t>(256, volume.size());
  std::vector<float> d;
  std::vector<uint32_t> idx(kVolumeRadiusK + 1);
  std::vector<float> d2(kVolumeRadiusK + 1);
  for (size_t j = 0; j < probes; ++j) {
    // Probes spread evenly through the photons (in trace order, so through the photon paths); the photon
    // itself is its own nearest, hence K + 1.
    const Photon& ph = volume[j * volume.size() / probes];
    const size_t n = tree.knn(ph.p, kVolumeRadiusK + 1, kInf, idx.data(), d2.data());
    if (n == size_t(kVolumeRadiusK + 1)) d.push_back(std::sqrt(d2[n - 1]));
  }
  if (d.empty()) return 0.f;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

int32_t outer_medium(const Scene& scene, const CpuAccel& accel, const std::string& integrator,
                     const std::string& paths) {
  const SceneView& v = scene.view();
  // Paths from lights start in the medium that encloses the light (locate_medium). Where the camera's forward
  // ray meets no boundary, the camera is in the region outside every boundary, whose medium is then the
  // camera's; where it meets one, the camera's medium must be the side it is on.
  // (From the lens itself: without the clipping planes.)
  Camera unclipped = v.camera;
  unclipped.near_clip = 0.f;
  unclipped.far_clip = kInf;
  Ray forward = unclipped.generate_ray(Vec2f(0.5f * v.camera.width, 0.5f * v.camera.height), Vec2f(0.5f, 0.5f));
  const int32_t found = locate_medium(v, [&](const Ray& r, Hit& h) { accel.intersect(r, h); }, forward, -2);
  if (found == -2) return v.camera_medium;
  if (found != v.camera_medium)
    throw InputError("integrator '" + integrator + "': the camera's medium is not the one enclosed by the shapes "
                     "around it (" + paths + " could not reach it); give the medium a closed boundary shape with it "
                     "as interior, or use --integrator path");
  return -1;
}

float photon_media_setup(const Scene& scene, const CpuAccel& accel, const RenderOptions& opt, uint64_t photons,
                         uint32_t photon_depth, float r0, int32_t* outside) {
  *outside = outer_medium(scene, accel, opt.integrator, "photons");
  if (opt.integrator == "pm") return 0.f;
  float rv = opt.volume_radius;
  if (!(rv > 0.f)) rv = automatic_volume_radius(scene, accel, opt.seed, photons, photon_depth, *outside);
  // No volume photons in a pass (a medium the lights do not reach): any radius gives the same zero.
  return rv > 0.f ? rv : r0;
}

std::vector<Photon> PhotonIntegrator::trace_photons(const SceneView& v, const CpuAccel& accel, uint64_t seed,
                                                    uint32_t pass, uint64_t count, uint32_t max_depth,
                                                    bool keep_direct, const std::atomic<bool>* cancel,
                                                    int32_t outside) {
  const uint64_t chunk = 4096;
  const uint64_t nchunks = (count + chunk - 1) / chunk;
  std::vector<std::vector<Photon>> parts(nchunks);
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, nchunks, 1), [&](const tbb::blocked_range<uint64_t>& r) {
    for (uint64_t c = r.begin(); c < r.end(); ++c) {
      if (cancel && cancel->load(std::memory_order_relaxed)) return;
      auto& out = parts[c];
      uint64_t end = std::min(count, (c + 1) * chunk);
      for (uint64_t i = c * chunk; i < end; ++i) {
        trace_photon(
            v, seed, pass, uint32_t(i), max_depth, [&](const Ray& ray, Hit& h) { return accel.intersect(ray, h); },
            [&](const Photon& ph) {
              if (keep_direct || !(ph.flags & kPhotonDirect)) out.push_back(ph);
            },
            outside);
      }
    }
  });
  size_t total = 0;
  for (auto& p : parts) total += p.size();
  std::vector<Photon> all;
  all.reserve(total);
  for (auto& p : parts) all.insert(all.end(), p.begin(), p.end());  // chunk order: deterministic
  return all;
}

PhotonIntegrator::PhotonIntegrator(std::shared_ptr<Scene> scene, const RenderOptions& opt)
    : scene_(std::move(scene)), opt_(opt) {
  const SceneView& v = scene_->view();
  kind_ = opt.integrator == "ppm"    ? Kind::kPPM
          : opt.integrator == "pppm" ? Kind::kPPPM
          : opt.integrator == "pm"   ? Kind::kPM
                                     : Kind::kSPPM;
  if (opt.k < 1) throw InputError("--k must be a positive integer");
  adaptive_ = opt.photon_sampling == "adaptive" && kind_ != Kind::kPM;
  int md = opt.max_depth == -2 ? scene_->desc().max_depth : opt.max_depth;
  max_depth_ = md < 0 ? 0xffffffffu : uint32_t(md);
  W_ = v.camera.width;
  H_ = v.camera.height;
  photons_per_pass_ = opt.photons > 0 ? uint64_t(opt.photons) : uint64_t(W_) * uint64_t(H_);
  if (opt.alpha <= 0.f || opt.alpha >= 1.f) throw InputError("--alpha must be in (0, 1), got " + std::to_string(opt.alpha));
  // Initial radius: twice the median pixel footprint (distance x pixel angle) of
  // camera rays to their first hit, if not given.
  r0_ = opt.radius;
  if (!(r0_ > 0.f)) r0_ = automatic_radius(*scene_);
  // Participating media: volume photons, and for ppm, pppm and sppm volume visible points with a volume
  // radius (pm takes its k nearest volume photons).
  media_ = scene_has_media(v);
  remeasure_ = media_ && kind_ == Kind::kPPM && scene_has_grid_media(v);
  if (media_)
    rv0_ = photon_media_setup(*scene_, scene_->cpu_accel(opt.accel), opt, photons_per_pass_,
                            max_depth_ == 0xffffffffu ? max_depth_ : max_depth_ - 1, r0_, &outer_medium_);
  size_t n = size_t(W_) * H_;
  K_ = kind_ == Kind::kPPM ? kPpmPointsPerPixel : 1;
  vp_.assign(n * K_ + (media_ && kind_ == Kind::kPPM ? n : 0), VisiblePoint());
  direct_.assign(3 * n, 0.0);
  if (kind_ == Kind::kPPPM) indirect_.assign(3 * n, 0.0);
  else if (kind_ == Kind::kPM) {
  } else {
    N_.assign(n * K_, 0.0);
    tau_.assign(3 * n * K_, 0.0);
    R_.assign(n * K_, r0_);
    if (media_) {
      Nv_.assign(n, 0.0);
      tauv_.assign(3 * n, 0.0);
      Rv_.assign(n, rv0_);
    }
  }
}

void PhotonIntegrator::trace_visible_points(int64_t abs_pass) {
  const SceneView& v = scene_->view();
  const CpuAccel& accel = scene_->cpu_accel(opt_.accel);
  PathParams pp;
  pp.seed = opt_.seed;
  pp.sampler = opt_.sampler;
  const bool light_bvh = opt_.light_sampler == "bvh";
  tbb::parallel_for(tbb::blocked_range<int>(0, H_, 1), [&](const tbb::blocked_range<int>& r) {
    for (int y = r.begin(); y < r.end(); ++y)
      for (int x = 0; x < W_; ++x) {
        PathState st;
        path_start(v, pp, uint32_t(x), uint32_t(y), uint32_t(abs_pass), st);
        RGB L(0.f);
        size_t i = size_t(y) * W_ + x;
        Ray camera_ray = st.ray;
        // The camera weight starts at the pixel filter's h / p (film/filter.h; negative in a negative lobe).
        VisiblePoint vp = trace_camera(v, accel, st.ray, RGB(st.weight), st.sampler, max_depth_, L, light_bvh, true,
                                       kCameraMedium, opt_.hide_emitters);
        if (kind_ != Kind::kPPM) vp_[i] = vp;
        else {
          // The pass's volume visible point (media): the camera rays that scatter before a surface.
          if (media_) vp_[volume_base() + i] = vp.volume ? vp : VisiblePoint();
          if (abs_pass == opt_.pass_offset || remeasure_)
            trace_measurement_points(v, accel, camera_ray, max_depth_, &vp_[i * K_], K_, uint64_t(abs_pass) + 1);
        }
        if (!isfinite3(L)) continue;
        for (int c = 0; c < 3; ++c) direct_[3 * i + c] += L[c];
      }
  });
}

void PhotonIntegrator::render_pm_pass(int64_t abs_pass) {
  const SceneView& v = scene_->view();
  const CpuAccel& accel = scene_->cpu_accel(opt_.accel);
  if (global_paths_ == 0) {
    // The maps are built once (two-pass photon mapping): all stored photons in the
    // global map, L S+ D photons in the caustic map, from the same photon paths; volume photons in maps of
    // their own (pm.h).
    std::vector<Photon> all = trace_photons(v, accel, opt_.seed, 0xfffffffu, photons_per_pass_,
                                            max_depth_ == 0xffffffffu ? max_depth_ : max_depth_ - 1, true, nullptr,
                                            outer_medium_);
    const PmPhotonSplit maps = pm_split_photons(all);
    global_.build(maps.global);
    caustic_.build(maps.caustic);
    volume_.build(maps.volume);
    volume_indirect_.build(maps.volume_indirect);
    global_paths_ = photons_per_pass_;
    traced_ += photons_per_pass_;
  }
  PathParams pp;
  pp.seed = opt_.seed;
  pp.sampler = opt_.sampler;
  const bool light_bvh = opt_.light_sampler == "bvh";
  const uint32_t k = uint32_t(opt_.k);
  tbb::parallel_for(tbb::blocked_range<int>(0, H_, 1), [&](const tbb::blocked_range<int>& r) {
    std::vector<uint32_t> idx(k);
    std::vector<float> d2(k);
    for (int y = r.begin(); y < r.end(); ++y)
      for (int x = 0; x < W_; ++x) {
        PathState st;
        path_start(v, pp, uint32_t(x), uint32_t(y), uint32_t(abs_pass), st);
        const RGB L = st.weight *
                      pm_radiance(v, accel, PmMaps<PhotonKdTree>{caustic_, global_, volume_, volume_indirect_},
                                  global_paths_, k, st.ray, st.sampler, max_depth_, light_bvh, idx.data(), d2.data(),
                                  opt_.hide_emitters);
        if (!isfinite3(L)) continue;
        size_t i = size_t(y) * W_ + x;
        for (int c = 0; c < 3; ++c) direct_[3 * i + c] += L[c];
      }
  });
}

bool PhotonIntegrator::render_pass(int64_t pass, const std::atomic<bool>& cancel) {
  const SceneView& v = scene_->view();
  const int64_t abs_pass = opt_.pass_offset + pass;
  if (kind_ == Kind::kPM) {
    render_pm_pass(abs_pass);  // runs to the end: its pixels are never half-updated
    return true;
  }
  // PPM keeps the measurement points of its first pass (Hachisuka et al. 2008,
  // Sec. 4.1) and re-estimates only their direct light; SPPM and PPPM draw new ones.
  // A pass that is cancelled or fails (an exception: out of memory) leaves direct_ as it was, so the image
  // stays that of the complete passes before it (RenderJob keeps it for the caller either way).
  struct RestoreDirect {
    std::vector<double>& current;
    std::vector<double> saved;
    bool commit = false;
    ~RestoreDirect() {
      if (!commit) current.swap(saved);
    }
  } restore{direct_, direct_};
  trace_visible_points(abs_pass);
  // A photon stored after k segments completes a path of k + 1 segments with a
  // visible point at the camera's first hit: limit photon paths to max_depth - 1
  // so path lengths match the path tracer's (exact for first-hit visible points;
  // points behind specular chains may exceed it by the chain's extra segments).
  uint32_t photon_depth = max_depth_ == 0xffffffffu ? max_depth_ : max_depth_ - 1;
  float rmax = kind_ == Kind::kPPPM ? pppm_radius(r0_, opt_.alpha, abs_pass) : *std::max_element(R_.begin(), R_.end());
  // Volume photons (scenes with media) go to a grid of their own, with their own radius.
  const float rv = !media_                ? 0.f
                   : kind_ == Kind::kPPPM ? pppm_volume_radius(rv0_, opt_.alpha, abs_pass)
                                          : *std::max_element(Rv_.begin(), Rv_.end());
  std::vector<Photon> photons =
      adaptive_ ? trace_photons_adaptive(abs_pass, photon_depth, rmax, rv, cancel)
                : trace_photons(v, scene_->cpu_accel(opt_.accel), opt_.seed, uint32_t(abs_pass), photons_per_pass_,
                                photon_depth, false, &cancel, outer_medium_);
  if (cancel.load()) return false;
  traced_ += photons_per_pass_;
  std::vector<Photon> volume_photons;
  if (media_) {
    auto is_volume = [](const Photon& ph) { return (ph.flags & kPhotonVolume) != 0; };
    auto mid = std::stable_partition(photons.begin(), photons.end(), [&](const Photon& ph) { return !is_volume(ph); });
    volume_photons.assign(mid, photons.end());
    photons.erase(mid, photons.end());
  }
  PhotonHashGrid grid, volume_grid;
  // Cells of twice the largest radius: a query sphere then overlaps at most 2x2x2 cells.
  grid.build(photons, v.bounds, 2.f * rmax, opt_.stochastic_hash, hash3(opt_.seed, uint64_t(abs_pass), 0x9d));
  const PhotonGridView gv = grid.view();
  if (media_)
    volume_grid.build(volume_photons, v.bounds, 2.f * rv, opt_.stochastic_hash,
                      hash3(opt_.seed, uint64_t(abs_pass), 0x9e));
  const PhotonGridView vgv = media_ ? volume_grid.view() : PhotonGridView();
  const double inv_np = 1.0 / double(photons_per_pass_);
  restore.commit = true;  // the gather below only computes (no allocation, no cancel check)
  if (adaptive_) chains_.commit(pass_counts_);
  const size_t row = size_t(W_) * K_;  // a task: a row's visible points
  tbb::parallel_for(tbb::blocked_range<size_t>(0, vp_.size(), row), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {  // visible point i (pixel i / K_, or a volume point below)
      const VisiblePoint& vp = vp_[i];
      if (!vp.valid) continue;
      double phi[3];
      uint32_t M;
      if (vp.volume) {  // in media (sppm.h): pixel j's (volume_base)
        const size_t j = i - volume_base();
        sppm_volume_gather(vp, v, vgv, kind_ == Kind::kPPPM ? rv : Rv_[j], max_depth_, phi, M);
        if (kind_ == Kind::kPPPM) pppm_add_volume(&indirect_[3 * j], vp.beta, phi, inv_np, rv);
        else sppm_update(Nv_[j], &tauv_[3 * j], Rv_[j], vp.beta, phi, M, opt_.alpha, 3);
        continue;
      }
      float radius = kind_ == Kind::kPPPM ? rmax : R_[i];
      sppm_gather(vp, gv, radius, max_depth_, phi, M);
      if (kind_ == Kind::kPPPM) pppm_add(&indirect_[3 * i], vp.beta, phi, inv_np, radius);
      else sppm_update(N_[i], &tau_[3 * i], R_[i], vp.beta, phi, M, opt_.alpha);
    }
  });
  return true;
}

std::vector<Photon> PhotonIntegrator::trace_photons_adaptive(int64_t abs_pass, uint32_t photon_depth, float rmax,
                                                             float rv, const std::atomic<bool>& cancel) {
  const SceneView& v = scene_->view();
  const CpuAccel& accel = scene_->cpu_accel(opt_.accel);
  // V(u) of photon/adaptive.h (adaptive_photons.h's AdaptiveVisibility) over a grid of the valid visible
  // points (surface and volume ones), in index order.
  std::vector<Photon> points;
  std::vector<uint32_t> point_vp;  // visible-point index of each grid record
  for (size_t i = 0; i < vp_.size(); ++i)
    if (vp_[i].valid) {
      Photon p;
      p.p = vp_[i].p;
      points.push_back(p);
      point_vp.push_back(uint32_t(i));
    }
  AdaptiveVisibility visible;
  visible.set_radii(v.bounds, rmax, rv);
  visible.max_depth = max_depth_;
  PhotonHashGrid point_grid;
  if (!points.empty()) point_grid.build(points, v.bounds, 2.f * visible.query_radius, false, 0, true);
  visible.points = point_grid.view();
  visible.point_vp = point_vp.data();
  visible.vp = vp_.data();
  visible.R = kind_ == Kind::kPPPM ? nullptr : R_.data();
  visible.Rv = media_ && kind_ != Kind::kPPPM ? Rv_.data() : nullptr;
  visible.volume_base = uint32_t(volume_base());
  const uint64_t n = photons_per_pass_;
  const uint32_t chains = adaptive_chain_count(n);
  const float d = chains_.mutation_size;
  std::vector<std::vector<Photon>> parts(chains);
  std::vector<ChainCounts> counts(chains);
  struct PhotonList {  // a path's visible photons
    std::vector<Photon> photons;
    void clear() { photons.clear(); }
    void push(const Photon& ph) { photons.push_back(ph); }
  };
  struct Buffers {
    PrimarySample samples[2];
    PhotonList payloads[2];
  };
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, chains, 1), [&](const tbb::blocked_range<uint32_t>& r) {
    auto buffers = std::make_unique<Buffers>();
    for (uint32_t c = r.begin(); c < r.end(); ++c) {
      std::vector<Photon>& out = parts[c];
      run_adaptive_photon_chain(
          v, accel, visible, photon_depth, opt_.seed, abs_pass, c, adaptive_chain_steps(n, chains, c), d,
          buffers->samples, buffers->payloads,
          [&](const PhotonList& state) { out.insert(out.end(), state.photons.begin(), state.photons.end()); },
          [&] { return cancel.load(std::memory_order_relaxed); }, counts[c], outer_medium_);
    }
  });
  if (cancel.load()) return {};
  ChainCounts pass_counts;
  for (const ChainCounts& c : counts) pass_counts.add(c);
  const float scale = float(pass_counts.deposit_scale());
  size_t total = 0;
  for (const auto& p : parts) total += p.size();
  std::vector<Photon> all;
  all.reserve(total);
  for (const auto& p : parts)
    for (Photon ph : p) {  // chain order: deterministic
      ph.power = ph.power * scale;
      all.push_back(ph);
    }
  pass_counts_ = pass_counts;
  return all;
}

AdaptiveSummary PhotonIntegrator::adaptive_summary() const {
  return adaptive_ ? chains_.summary() : AdaptiveSummary();
}

std::vector<float> photon_image(size_t pixels, int K, int64_t passes, uint64_t photons_per_pass, PhotonEstimate kind,
                                const std::vector<double>& direct, const std::vector<double>& tau,
                                const std::vector<float>& R, const std::vector<double>& indirect,
                                const std::vector<double>* tau_v, const std::vector<float>* R_v) {
  std::vector<float> img(3 * pixels, 0.f);
  if (passes <= 0) return img;
  double emitted = double(passes) * double(photons_per_pass);
  for (size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < 3; ++c) {
      double L = direct[3 * i + c] / double(passes);
      if (kind == PhotonEstimate::kPerPass) L += indirect[3 * i + c] / double(passes);
      else if (kind == PhotonEstimate::kProgressive)
        for (int k = 0; k < K; ++k) {
          size_t j = i * K + k;
          L += tau[3 * j + c] / (emitted * double(kPi) * double(R[j]) * R[j]);
        }
      if (kind == PhotonEstimate::kProgressive && tau_v && !tau_v->empty()) {
        const double r = (*R_v)[i];
        L += (*tau_v)[3 * i + c] / (emitted * 4.0 / 3.0 * double(kPi) * r * r * r);
      }
      img[3 * i + c] = float(L);
    }
  return img;
}

std::vector<float> PhotonIntegrator::image(int64_t passes) const {
  PhotonEstimate e = kind_ == Kind::kPPPM ? PhotonEstimate::kPerPass
                     : kind_ == Kind::kPM ? PhotonEstimate::kNone
                                          : PhotonEstimate::kProgressive;
  return photon_image(size_t(W_) * H_, K_, passes, photons_per_pass_, e, direct_, tau_, R_, indirect_, &tauv_, &Rv_);
}

}  // namespace caustica
