// The WavefrontRenderer handles (wavefront_render.h) over any backend: the path tracer, the photon
// integrators and the bidirectional ones, turning their device statistics into images the way the CPU drivers do. Included by the
// CPU backend's factory (wavefront_render.cpp) and the CUDA backend's (backend/cuda/cuda_render.cu).
#pragma once
#include <string>

#include "photon_render.h"
#include "render.h"
#include "wavefront_path.h"
#include "wavefront_photon.h"
#include "wavefront_restir.h"
#include "wavefront_vcm.h"

namespace caustica {

// The renderers of the drivers that add one sample per pixel and pass to a WavefrontFilm (wavefront_film.h): their
// image is the film's, as the CPU path tracer's (render.h's Film).
template <class Driver>
class FilmWavefrontRenderer : public WavefrontRenderer {
 public:
  template <class B, class... Args>
  FilmWavefrontRenderer(const B& b, std::string name, const Args&... args)
      : wf_(b, args...), name_(std::move(name)), W_(b.scene().camera.width), H_(b.scene().camera.height) {}
  bool render_pass(uint32_t pass, const std::atomic<bool>* cancel, WavefrontPassStats& stats) override {
    return wf_.render_pass(pass, cancel, stats);
  }
  std::vector<float> image(int64_t) const override {
    Film f(W_, H_);
    wf_.film(f.sum, f.odd);
    return f.image();
  }
  std::string device_name() const override { return name_; }

 protected:
  Driver wf_;

 private:
  std::string name_;
  int W_, H_;
};

// The path tracer also hands its film out (the half images of --target-noise).
template <class B>
class PathWavefrontRenderer final : public FilmWavefrontRenderer<WavefrontPath<B>> {
 public:
  PathWavefrontRenderer(const B& b, std::string name, const PathParams& pp, const WavefrontOptions& opt,
                        uint32_t num_materials)
      : FilmWavefrontRenderer<WavefrontPath<B>>(b, std::move(name), pp, opt, num_materials) {}
  bool film(std::vector<double>& sum, std::vector<double>& odd) const override {
    this->wf_.film(sum, odd);
    return true;
  }
};

template <class B>
class PhotonWavefrontRenderer final : public WavefrontRenderer {
 public:
  PhotonWavefrontRenderer(const B& b, std::string name, const PhotonWavefrontParams& p)
      : wf_(b, p), p_(p), name_(std::move(name)),
        pixels_(size_t(b.scene().camera.width) * size_t(b.scene().camera.height)) {}
  bool render_pass(uint32_t pass, const std::atomic<bool>* cancel, WavefrontPassStats& stats) override {
    return wf_.render_pass(pass, cancel, stats);
  }
  std::vector<float> image(int64_t passes) const override {
    std::vector<double> direct, tau, indirect, tau_v;
    std::vector<float> R, R_v;
    wf_.statistics(direct, tau, R, indirect, tau_v, R_v);
    return photon_image(pixels_, wf_.points_per_pixel(), passes, p_.photons,
                        p_.pm     ? PhotonEstimate::kNone
                        : p_.pppm ? PhotonEstimate::kPerPass
                                  : PhotonEstimate::kProgressive,
                        direct, tau, R, indirect, &tau_v, &R_v);
  }
  std::string device_name() const override { return name_; }
  float initial_radius() const override { return p_.radius; }
  AdaptiveSummary adaptive_summary() const override { return wf_.adaptive_summary(); }

 private:
  WavefrontPhoton<B> wf_;
  PhotonWavefrontParams p_;
  std::string name_;
  size_t pixels_;
};

template <class B>
class VcmWavefrontRenderer final : public WavefrontRenderer {
 public:
  VcmWavefrontRenderer(const B& b, std::string name, const VcmWavefrontParams& p)
      : wf_(b, p), r0_(p.radius), name_(std::move(name)) {}
  bool render_pass(uint32_t pass, const std::atomic<bool>* cancel, WavefrontPassStats& stats) override {
    return wf_.render_pass(pass, cancel, stats);
  }
  std::vector<float> image(int64_t passes) const override { return wf_.image(passes); }
  std::string device_name() const override { return name_; }
  float initial_radius() const override { return r0_; }

 private:
  WavefrontVcm<B> wf_;
  float r0_;
  std::string name_;
};

template <class B>
using RestirWavefrontRenderer = FilmWavefrontRenderer<WavefrontRestir<B>>;

// A renderer that owns a backend (and what the backend needs) and forwards every call to the renderer built
// over it; enter() runs first (the CUDA backend makes its device current there).
class OwningRenderer : public WavefrontRenderer {
 public:
  bool render_pass(uint32_t pass, const std::atomic<bool>* cancel, WavefrontPassStats& stats) override {
    enter();
    return inner_->render_pass(pass, cancel, stats);
  }
  std::vector<float> image(int64_t passes) const override {
    enter();
    return inner_->image(passes);
  }
  bool film(std::vector<double>& sum, std::vector<double>& odd) const override {
    enter();
    return inner_->film(sum, odd);
  }
  std::string device_name() const override { return inner_->device_name(); }
  float initial_radius() const override { return inner_->initial_radius(); }
  AdaptiveSummary adaptive_summary() const override { return inner_->adaptive_summary(); }

 protected:
  virtual void enter() const {}
  std::unique_ptr<WavefrontRenderer> inner_;
};

}  // namespace caustica
