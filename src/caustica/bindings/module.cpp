// The Python extension `caustica._native`: scenes, render jobs (rendering on a
// C++ thread without the GIL), image output and the BSDF/sampling routines the
// tests need. The pure-Python package (python/caustica) builds the API on it.
#include <initializer_list>
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/map.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/shared_ptr.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "../backend/cuda/cuda_render.h"
#include "../base/error.h"
#include "../film/image_io.h"
#include "../integrator/render.h"
#include "../scene/builtin/builtin.h"
#include "../scene/json_writer.h"
#include "../scene/load.h"
#include "../scene/loaders/json_loader.h"

namespace nb = nanobind;
using namespace caustica;

namespace {

nb::ndarray<nb::numpy, float> to_numpy(std::vector<float>&& v, int h, int w) {
  auto* data = new std::vector<float>(std::move(v));
  nb::capsule owner(data, [](void* p) noexcept { delete static_cast<std::vector<float>*>(p); });
  size_t shape[3] = {size_t(h), size_t(w), 3};
  return nb::ndarray<nb::numpy, float>(data->data(), 3, shape, owner);
}


// Scene-file problems reach Python as caustica.SceneError (a subclass of InputError).
struct SceneError : InputError {
  using InputError::InputError;
};

template <typename F>
auto scene_call(F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const SceneError&) {
    throw;
  } catch (const InputError& e) {
    throw SceneError(e.what());
  }
}

SceneDesc load_desc(const std::string& name_or_path, const std::string& camera,
                    const std::map<std::string, std::string>& params, const std::string& variant) {
  LoadOptions o;
  o.camera = camera;
  o.params = params;
  o.variant = variant;
  return scene_call([&] {
    SceneDesc d = load_scene_desc(name_or_path, o);
    // load_scene_desc picks cameras of files; a built-in scene has none to pick.
    if (!camera.empty() && d.camera.name != camera) select_camera(d, camera);
    return d;
  });
}

SceneDesc load_json_desc(const std::string& text, const std::string& source, const std::string& base_dir,
                         const std::string& camera) {
  return scene_call([&] {
    SceneDesc d = load_json_scene_text(text, source, base_dir);
    if (!camera.empty()) select_camera(d, camera);
    return d;
  });
}

std::shared_ptr<Scene> build_scene(const SceneDesc& d) {
  return scene_call([&] { return Scene::build(d); });
}

// A camera's crop window as (x, y, width, height), or None for the whole film.
nb::object crop_tuple(const CameraDesc& c) {
  if (c.crop_width <= 0) return nb::none();
  return nb::make_tuple(c.crop_x, c.crop_y, c.crop_width, c.crop_height);
}

nb::dict describe(const SceneDesc& d) {
  SceneStats st = scene_stats(d);
  nb::dict r;
  r["name"] = d.name;
  r["shapes"] = st.shapes;
  r["meshes"] = st.meshes;
  r["triangles"] = st.triangles;
  r["spheres"] = st.spheres;
  r["materials"] = st.materials;
  r["lights"] = st.lights;
  r["area_lights"] = st.area_lights;
  r["textures"] = st.textures;
  r["media"] = d.media.size();
  size_t grid_media = 0, emissive_media = 0;
  for (const Medium& m : d.media) {
    grid_media += m.grid >= 0;
    emissive_media += medium_emits(m);
  }
  r["heterogeneous_media"] = grid_media;
  r["emissive_media"] = emissive_media;
  nb::list lo, hi;
  for (int i = 0; i < 3; ++i) {
    lo.append(st.lo[i]);
    hi.append(st.hi[i]);
  }
  r["bounds"] = nb::make_tuple(lo, hi);
  const CameraDesc& c = d.camera;
  r["projection"] = c.orthographic ? "orthographic" : (c.aperture_radius > 0.f ? "thin lens" : "perspective");
  if (c.moving) r["shutter"] = nb::make_tuple(c.shutter_open, c.shutter_close);
  else r["shutter"] = nb::none();
  r["crop"] = crop_tuple(c);
  if (c.near_clip > 0.f || c.far_clip < kInf) r["clip"] = nb::make_tuple(c.near_clip, c.far_clip);
  else r["clip"] = nb::none();
  return r;
}

nb::dict integrator_defaults(const SceneDesc& d) {
  const SceneDesc::IntegratorDefaults& in = d.integrator;
  nb::dict r;
  if (!in.type.empty()) r["integrator"] = in.type;
  if (!in.sampler.empty()) r["sampler"] = in.sampler;
  if (in.spp > 0) r["spp"] = in.spp;
  if (in.time > 0.0) r["time"] = in.time;
  if (d.max_depth != -1) r["max_depth"] = d.max_depth;
  if (in.rr_depth > 0) r["rr_depth"] = in.rr_depth;
  if (in.photons > 0) r["photons"] = in.photons;
  if (in.radius > 0.f) r["radius"] = in.radius;
  if (in.alpha > 0.f) r["alpha"] = in.alpha;
  if (in.k > 0) r["k"] = in.k;
  if (!in.photon_sampling.empty()) r["photon_sampling"] = in.photon_sampling;
  if (!in.light_sampler.empty()) r["light_sampler"] = in.light_sampler;
  if (in.restir_candidates >= 0) r["restir_candidates"] = in.restir_candidates;
  if (in.restir_neighbors >= 0) r["restir_neighbors"] = in.restir_neighbors;
  if (in.restir_radius >= 0.f) r["restir_radius"] = in.restir_radius;
  if (in.restir_history >= 0.f) r["restir_history"] = in.restir_history;
  if (in.hide_emitters >= 0) r["hide_emitters"] = in.hide_emitters == 1;
  return r;
}

std::vector<std::string> camera_names(const SceneDesc& d) {
  std::vector<std::string> n;
  for (const CameraDesc& c : d.cameras) n.push_back(c.name);
  return n;
}

// A filter's parameters by the scene format's names (radius, and stddev, B and C, or lobes).
nb::dict filter_parameters(const Filter& f) {
  nb::dict d;
  d["radius"] = f.radius;
  if (f.type == FilterType::kGaussian) d["stddev"] = f.a;
  if (f.type == FilterType::kMitchell) {
    d["B"] = f.a;
    d["C"] = f.b;
  }
  if (f.type == FilterType::kLanczos) d["lobes"] = f.a;
  return d;
}

// The description with the overrides applied since loading (resolution is in desc; the filter only in the view).
SceneDesc current_desc(const Scene& s) {
  SceneDesc d = s.desc();
  d.filter = s.view().filter;
  return d;
}


}  // namespace

static nb::dict stats_dict(const RenderJob& j, const RenderStats& s) {
  nb::dict d;
  d["passes"] = s.passes;
  d["target_passes"] = s.target_passes;
  d["samples"] = s.samples;
  d["rays"] = s.rays;
  d["shadow_rays"] = s.shadow_rays;
  d["invalid_samples"] = s.invalid_samples;
  d["seconds"] = s.seconds;
  d["done"] = s.done;
  d["cancelled"] = s.cancelled;
  d["photons"] = s.photons;
  d["radius"] = s.radius;
  if (s.volume_radius > 0.f) d["volume_radius"] = s.volume_radius;  // ppm, pppm, sppm, bpm, vcm in media
  if (s.adaptive.visible >= 0.0) {  // --photon-sampling adaptive
    nb::dict a;
    a["visible_fraction"] = s.adaptive.visible;
    a["acceptance"] = s.adaptive.acceptance;
    a["mutation_size"] = s.adaptive.mutation_size;
    d["adaptive"] = a;
  }
  d["error"] = s.error >= 0.0 ? nb::cast(s.error) : nb::none();
  d["noise"] = s.noise >= 0.0 ? nb::cast(s.noise) : nb::none();
  d["target_reached"] = s.target_reached;
  d["lanes"] = s.lanes;
  d["device"] = j.device_name();
  d["accel"] = j.accel_name();
  // Wavefront renders: seconds per stage, and the grid's input (photons, or the bidirectional light vertices).
  auto stages = [&](std::initializer_list<std::pair<const char*, double>> named) {
    nb::dict st;
    for (const auto& [name, seconds] : named) st[name] = seconds;
    d["stage_seconds"] = st;
    d["stored_photons"] = s.stored_photons;
  };
  if (s.seconds_light + s.seconds_camera + s.seconds_accumulate > 0.0)
    stages({{"light_subpaths", s.seconds_light}, {"grid", s.seconds_grid}, {"camera_subpaths", s.seconds_camera},
            {"accumulate", s.seconds_accumulate}});
  else if (s.seconds_visible + s.seconds_photons + s.seconds_grid + s.seconds_gather > 0.0)
    stages({{"visible_points", s.seconds_visible}, {"photons", s.seconds_photons}, {"grid", s.seconds_grid},
            {"gather", s.seconds_gather}});
  return d;
}

NB_MODULE(_native, m) {
  nb::exception<InputError>(m, "InputError", PyExc_ValueError);
  nb::exception<SceneError>(m, "SceneError", m.attr("InputError"));

  m.def("builtin_scenes", &builtin_scenes);
  m.def("default_scene_name", &default_scene_name);
  m.def("integrator_names", &integrator_names);
  m.def("cuda_built", &cuda_built);
  // The CUDA devices this process can use, and when there are none, why (one line).
  m.def("cuda_devices", [] {
    std::string why;
    std::vector<CudaDeviceInfo> list = cuda_devices(&why);
    nb::list out;
    for (const CudaDeviceInfo& d : list) {
      nb::dict e;
      e["index"] = d.index;
      e["name"] = d.name;
      e["memory"] = d.memory;
      e["compute_capability"] = std::to_string(d.major) + "." + std::to_string(d.minor);
      e["multiprocessors"] = d.multiprocessors;
      out.append(e);
    }
    return nb::make_tuple(out, why);
  });

  nb::class_<Scene>(m, "Scene")
      .def_prop_ro("name", [](const Scene& s) { return s.desc().name; })
      .def_prop_ro("width", [](const Scene& s) { return s.view().camera.width; })
      .def_prop_ro("height", [](const Scene& s) { return s.view().camera.height; })
      .def_prop_ro("filter", [](const Scene& s) { return std::string(filter_type_name(s.view().filter.type)); })
      .def_prop_ro("filter_parameters", [](const Scene& s) { return filter_parameters(s.view().filter); },
                   "the pixel filter's parameters: radius (pixels), and stddev, B and C, or lobes")
      .def_prop_ro("max_depth", [](const Scene& s) { return s.desc().max_depth; })
      .def_prop_ro("num_triangles", [](const Scene& s) { return s.view().num_triangles; })
      .def_prop_ro("num_spheres", [](const Scene& s) { return s.view().num_spheres; })
      .def_prop_ro("num_lights", [](const Scene& s) { return s.view().num_lights; })
      .def_prop_ro("bounding_radius", [](const Scene& s) { return s.view().bsphere_radius; })
      .def("set_resolution", [](Scene& s, int w, int h) {
        if (w <= 0 || h <= 0) throw InputError("width and height must be positive integers");
        s.set_resolution(w, h);
      }, "sets the film's size (with a crop window, the whole film's; the window must still fit)")
      .def_prop_ro("film_size", [](const Scene& s) { return nb::make_tuple(s.desc().camera.width, s.desc().camera.height); },
                   "the whole film's (width, height); width and height are the image's (the crop window's)")
      .def_prop_ro("crop", [](const Scene& s) { return crop_tuple(s.desc().camera); },
                   "the crop window (x, y, width, height) in pixels of the film, or None")
      .def("set_crop", [](Scene& s, int x, int y, int w, int h) { s.set_crop(x, y, w, h); },
           "renders the film's pixels [x, x + w) x [y, y + h) only (all 0: the whole film)")
      .def("set_filter", [](Scene& s, const std::string& f) { s.set_filter(filter_by_name(f)); })
      .def("set_filter_json", [](Scene& s, const std::string& j) { s.set_filter(parse_filter_json(j, "filter")); })
      .def_prop_ro("warnings", [](const Scene& s) { return s.desc().warnings; })
      .def_prop_ro("cameras", [](const Scene& s) { return camera_names(s.desc()); })
      .def_prop_ro("camera", [](const Scene& s) { return s.desc().camera.name; })
      .def_prop_ro("variants", [](const Scene& s) { return s.desc().variants; })
      .def_prop_ro("variant", [](const Scene& s) { return s.desc().variant; })
      .def_prop_ro("integrator_defaults", [](const Scene& s) { return integrator_defaults(s.desc()); })
      .def("describe", [](const Scene& s) { return describe(s.desc()); },
           "Counts (shapes, meshes, triangles, spheres, materials, lights, area_lights, textures, media) and world bounds.")
      .def("to_json", [](const Scene& s, const std::string& texture_stem) {
             return scene_call([&] { return scene_desc_to_json(current_desc(s), texture_stem); });
           },
           nb::arg("texture_stem") = "scene")
      .def("write_json", [](const Scene& s, const std::string& path) {
             nb::gil_scoped_release release;
             scene_call([&] { write_scene_json(current_desc(s), path); });
           });

  // A loaded description without acceleration structures (for info and export of large scenes).
  nb::class_<SceneDesc>(m, "SceneDesc")
      .def_prop_ro("name", [](const SceneDesc& d) { return d.name; })
      .def_prop_ro("width", [](const SceneDesc& d) { return d.camera.crop_width > 0 ? d.camera.crop_width : d.camera.width; })
      .def_prop_ro("height", [](const SceneDesc& d) { return d.camera.crop_width > 0 ? d.camera.crop_height : d.camera.height; })
      .def_prop_ro("film_size", [](const SceneDesc& d) { return nb::make_tuple(d.camera.width, d.camera.height); })
      .def_prop_ro("crop", [](const SceneDesc& d) { return crop_tuple(d.camera); })
      .def_prop_ro("filter", [](const SceneDesc& d) { return std::string(filter_type_name(d.filter.type)); })
      .def_prop_ro("filter_parameters", [](const SceneDesc& d) { return filter_parameters(d.filter); })
      .def_prop_ro("max_depth", [](const SceneDesc& d) { return d.max_depth; })
      .def_prop_ro("warnings", [](const SceneDesc& d) { return d.warnings; })
      .def_prop_ro("cameras", [](const SceneDesc& d) { return camera_names(d); })
      .def_prop_ro("camera", [](const SceneDesc& d) { return d.camera.name; })
      .def_prop_ro("variants", [](const SceneDesc& d) { return d.variants; })
      .def_prop_ro("variant", [](const SceneDesc& d) { return d.variant; })
      .def_prop_ro("integrator_defaults", [](const SceneDesc& d) { return integrator_defaults(d); })
      .def("describe", [](const SceneDesc& d) { return describe(d); })
      .def("to_json", [](const SceneDesc& d, const std::string& texture_stem) {
             return scene_call([&] { return scene_desc_to_json(d, texture_stem); });
           },
           nb::arg("texture_stem") = "scene")
      .def("write_json", [](const SceneDesc& d, const std::string& path) {
             nb::gil_scoped_release release;
             scene_call([&] { write_scene_json(d, path); });
           })
      .def("build", [](const SceneDesc& d) { return build_scene(d); }, nb::call_guard<nb::gil_scoped_release>());
  m.def("load_scene_desc",
        [](const std::string& name_or_path, const std::string& camera, const std::map<std::string, std::string>& params,
           const std::string& variant) {
          return load_desc(name_or_path, camera, params, variant);
        },
        nb::arg("name_or_path"), nb::arg("camera") = "", nb::arg("params") = std::map<std::string, std::string>(),
        nb::arg("variant") = "",
        nb::call_guard<nb::gil_scoped_release>());
  m.def("load_json_desc", &load_json_desc, nb::arg("text"), nb::arg("source"), nb::arg("base_dir") = "",
        nb::arg("camera") = "", nb::call_guard<nb::gil_scoped_release>());

  m.def("load_scene",
        [](const std::string& name_or_path, const std::string& camera, const std::map<std::string, std::string>& params,
           const std::string& variant) {
          return build_scene(load_desc(name_or_path, camera, params, variant));
        },
        nb::arg("name_or_path"), nb::arg("camera") = "", nb::arg("params") = std::map<std::string, std::string>(),
        nb::arg("variant") = "",
        nb::call_guard<nb::gil_scoped_release>());
  m.def("load_scene_json",
        [](const std::string& text, const std::string& source, const std::string& base_dir, const std::string& camera) {
          return build_scene(load_json_desc(text, source, base_dir, camera));
        },
        nb::arg("text"), nb::arg("source"), nb::arg("base_dir") = "", nb::arg("camera") = "",
        nb::call_guard<nb::gil_scoped_release>());
  // Loading without building (no acceleration structures): for export and describe.
  m.def("export_scene",
        [](const std::string& name_or_path, const std::string& out, const std::string& camera,
           const std::map<std::string, std::string>& params, const std::string& variant) {
          SceneDesc d = load_desc(name_or_path, camera, params, variant);
          scene_call([&] { write_scene_json(d, out); });
          return d.warnings;
        },
        nb::arg("name_or_path"), nb::arg("out"), nb::arg("camera") = "",
        nb::arg("params") = std::map<std::string, std::string>(), nb::arg("variant") = "",
        nb::call_guard<nb::gil_scoped_release>());
  m.def("export_scene_json",
        [](const std::string& text, const std::string& source, const std::string& base_dir, const std::string& out,
           const std::string& camera) {
          SceneDesc d = load_json_desc(text, source, base_dir, camera);
          scene_call([&] { write_scene_json(d, out); });
          return d.warnings;
        },
        nb::arg("text"), nb::arg("source"), nb::arg("base_dir"), nb::arg("out"), nb::arg("camera") = "",
        nb::call_guard<nb::gil_scoped_release>());
  m.def("scene_to_json",
        [](const std::string& name_or_path, const std::string& camera, const std::map<std::string, std::string>& params,
           const std::string& variant) {
          SceneDesc d = load_desc(name_or_path, camera, params, variant);
          return scene_call([&] { return scene_desc_to_json(d, d.name); });
        },
        nb::arg("name_or_path"), nb::arg("camera") = "", nb::arg("params") = std::map<std::string, std::string>(),
        nb::arg("variant") = "",
        nb::call_guard<nb::gil_scoped_release>());

  nb::class_<RenderJob>(m, "RenderJob")
      .def("__init__",
           [](RenderJob* self, std::shared_ptr<Scene> scene, const std::string& integrator, int64_t spp, double time,
              uint64_t seed, int threads, int max_depth, int rr_depth, const std::string& sampler,
              const std::string& accel, int64_t photons, float radius, float alpha, int64_t pass_offset,
              bool stochastic_hash, int k, double target_error,
              std::optional<nb::ndarray<const float, nb::ndim<3>, nb::c_contig, nb::device::cpu>> reference,
              double target_noise, bool strategy_images, const std::string& device, bool wavefront,
              bool compaction, bool sort_materials, bool cache_first_bounce, bool jitter, bool lanes,
              const std::string& photon_sampling, int restir_candidates, int restir_neighbors, float restir_radius,
              float restir_history, const std::string& light_sampler, float volume_radius, bool hide_emitters, const std::string& aov) {
             RenderOptions o;
             o.integrator = integrator;
             o.spp = spp;
             o.time = time;
             o.seed = seed;
             o.threads = threads;
             o.max_depth = max_depth;
             o.rr_depth = rr_depth;
             if (sampler == "sobol") o.sampler = SamplerType::kSobol;
             else if (sampler == "independent") o.sampler = SamplerType::kIndependent;
             else throw InputError("unknown sampler '" + sampler + "' (allowed: sobol, independent)");
             o.accel = accel;
             o.photons = photons;
             o.radius = radius;
             o.volume_radius = volume_radius;
             o.alpha = alpha;
             o.pass_offset = pass_offset;
             o.stochastic_hash = stochastic_hash;
             o.k = k;
             o.target_error = target_error;
             o.target_noise = target_noise;
             o.strategy_images = strategy_images;
             o.device = device;
             o.wavefront = wavefront;
             o.compaction = compaction;
             o.sort_materials = sort_materials;
             o.cache_first_bounce = cache_first_bounce;
             o.jitter = jitter;
             o.lanes = lanes;
             o.photon_sampling = photon_sampling;
             o.restir_candidates = restir_candidates;
             o.restir_neighbors = restir_neighbors;
             o.restir_radius = restir_radius;
             o.restir_history = restir_history;
             o.light_sampler = light_sampler;
             o.hide_emitters = hide_emitters;
             o.aov = aov;
             if (reference) {
               if (reference->shape(2) != 3) throw InputError("the reference image must have 3 channels (H, W, 3)");
               const float* p = reference->data();
               o.reference.assign(p, p + reference->size());
             }
             nb::gil_scoped_release release;
             new (self) RenderJob(std::move(scene), o);
           },
           nb::arg("scene"), nb::arg("integrator") = "path", nb::arg("spp") = 0, nb::arg("time") = 0.0,
           nb::arg("seed") = 0, nb::arg("threads") = 0, nb::arg("max_depth") = -2, nb::arg("rr_depth") = 5,
           nb::arg("sampler") = "sobol", nb::arg("accel") = "auto", nb::arg("photons") = 0,
           nb::arg("radius") = 0.f, nb::arg("alpha") = 0.7f, nb::arg("pass_offset") = 0,
           nb::arg("stochastic_hash") = false, nb::arg("k") = 50, nb::arg("target_error") = 0.0,
           nb::arg("reference") = nb::none(), nb::arg("target_noise") = 0.0, nb::arg("strategy_images") = false,
           nb::arg("device") = "cpu", nb::arg("wavefront") = false, nb::arg("compaction") = true,
           nb::arg("sort_materials") = false, nb::arg("cache_first_bounce") = false, nb::arg("jitter") = true,
           nb::arg("lanes") = true, nb::arg("photon_sampling") = "uniform", nb::arg("restir_candidates") = 32,
           nb::arg("restir_neighbors") = 5, nb::arg("restir_radius") = 30.f, nb::arg("restir_history") = 20.f,
           nb::arg("light_sampler") = "power", nb::arg("volume_radius") = 0.f, nb::arg("hide_emitters") = false,
           nb::arg("aov") = "")
      .def("start", &RenderJob::start)
      .def("run", &RenderJob::run, nb::call_guard<nb::gil_scoped_release>())
      .def("wait", &RenderJob::wait, nb::arg("timeout"), nb::call_guard<nb::gil_scoped_release>())
      .def("cancel", &RenderJob::cancel)
      .def("device_name", &RenderJob::device_name)
      .def("stats", [](const RenderJob& j) { return stats_dict(j, j.stats()); })
      // The image and the counters that match it, taken together between passes.
      .def("snapshot", [](const RenderJob& j) {
        std::vector<float> img;
        RenderStats s;
        {
          nb::gil_scoped_release release;
          img = j.image(&s);
        }
        return nb::make_tuple(to_numpy(std::move(img), j.height(), j.width()), stats_dict(j, s));
      })
      .def("image", [](const RenderJob& j) {
        std::vector<float> img;
        {
          nb::gil_scoped_release release;
          img = j.image();
        }
        return to_numpy(std::move(img), j.height(), j.width());
      })
      .def("strategy_images", [](const RenderJob& j) {
        std::vector<std::pair<std::string, std::vector<float>>> v;
        {
          nb::gil_scoped_release release;
          v = j.strategy_images();
        }
        nb::dict d;
        for (auto& e : v) d[e.first.c_str()] = to_numpy(std::move(e.second), j.height(), j.width());
        return d;
      });

  m.def("write_image",
        [](const std::string& path, nb::ndarray<const float, nb::ndim<3>, nb::c_contig, nb::device::cpu> a,
           float exposure) {
          if (a.shape(2) != 3) throw InputError("write_image: expected an (H, W, 3) float32 array");
          std::vector<float> v(a.data(), a.data() + a.size());
          int h = int(a.shape(0)), w = int(a.shape(1));
          nb::gil_scoped_release release;
          write_image(path, v, w, h, exposure);
        },
        nb::arg("path"), nb::arg("image"), nb::arg("exposure") = 0.f);
  m.def("read_image", [](const std::string& path) {
    int w = 0, h = 0;
    std::vector<float> v = read_image(path, w, h);
    return to_numpy(std::move(v), h, w);
  });
  m.def("is_supported_image_extension", &is_supported_image_extension);
}
