"""The Python API over the native module."""
from __future__ import annotations

import json
import math
import operator
import os
import time as _time
import warnings as _warnings
from dataclasses import dataclass, field
from typing import Any, Callable, Optional, Sequence, Union

import numpy as np

from . import _native

__version__ = "0.1.0"
InputError = _native.InputError
SceneError = _native.SceneError  # a scene file (or dict) that cannot be loaded; a subclass of InputError
Scene = _native.Scene


class SceneWarning(UserWarning):
    """Something in a scene file was skipped or replaced (e.g. a default camera); the scene still loads."""

SAMPLERS = ("sobol", "independent")
FILTERS = ("box", "tent", "gaussian", "mitchell", "catmullrom", "lanczos")
ACCELS = ("auto", "embree", "small", "bvh")


def builtin_scenes() -> list[tuple[str, str]]:
    """(name, description) of every built-in scene, the default first."""
    return list(_native.builtin_scenes())


def default_scene_name() -> str:
    return _native.default_scene_name()


def integrators() -> list[str]:
    return list(_native.integrator_names())


DEVICES = ("cpu", "cuda")
# The integrators with a wavefront driver: they run with device="cuda" and with wavefront=True (the native
# RenderOptions check in render.cpp holds the same list; tests/python/test_study.py compares the two).
CUDA_INTEGRATORS = ("path", "sppm", "ppm", "pppm", "pm", "light", "bdpt", "bpm", "vcm", "upg", "restir")


def _cpu_name() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "CPU"


def cuda_status() -> tuple[list[dict], str]:
    """(CUDA devices, why there are none): each device a dict with index, name, memory (bytes),
    compute_capability and multiprocessors. Empty without the CUDA backend in this build, a driver or a GPU,
    and then the string says which."""
    devs, why = _native.cuda_devices()
    return [dict(d) for d in devs], ("" if devs else why)


def devices() -> list[dict]:
    """The devices this build and machine can render on: [{"name": "cpu", "description": ...}, {"name":
    "cuda:0", ...}]. "cuda" means "cuda:0". Without a usable GPU only "cpu" is listed (cuda_status() says
    why)."""
    out = [{"name": "cpu", "description": f"{_cpu_name()}, {os.cpu_count()} threads (Embree, oneTBB)"}]
    for d in cuda_status()[0]:
        out.append({"name": f"cuda:{d['index']}",
                    "description": f"{d['name']}, {d['memory'] / 2**30:.0f} GiB, compute capability "
                                   f"{d['compute_capability']}, {d['multiprocessors']} SMs (wavefront drivers)"})
    return out


def _check_device_name(device: str) -> None:
    if not isinstance(device, str) or not (device in DEVICES or
                                           (device.startswith("cuda:") and device[5:].isdigit())):
        raise InputError(f"unknown device '{device}' (allowed: cpu, cuda, cuda:N)")


def _check_device(device: str) -> None:
    _check_device_name(device)
    if device == "cpu":
        return
    devs, why = cuda_status()
    index = 0 if device == "cuda" else int(device[5:])
    if not devs:
        raise InputError(f"device '{device}' is not available: {why} (`caustica devices` lists what is)")
    if index >= len(devs):
        raise InputError(f"device '{device}' does not exist (this machine has {len(devs)} CUDA device(s); "
                         f"`caustica devices` lists them)")


def _params(params: Optional[dict]) -> dict:
    """Mitsuba XML $name substitutions as strings (booleans as true/false)."""
    if params is None:
        return {}
    if not isinstance(params, dict):
        raise InputError(f"params: expected a dict of name -> value, got {type(params).__name__}")
    out = {}
    for k, v in params.items():
        if not isinstance(k, str) or not k:
            raise InputError(f"params: expected non-empty string names, got {k!r}")
        out[k] = ("true" if v else "false") if isinstance(v, bool) else str(v)
    return out


def _name(what: str, v: Optional[str]) -> str:
    if v is None:
        return ""
    if not isinstance(v, str) or not v:
        raise InputError(f"{what}: expected a {what} name, got {v!r}")
    return v


def _camera(camera: Optional[str]) -> str:
    return _name("camera", camera)


def _variant(variant: Optional[str]) -> str:
    return _name("variant", variant)


def _check_loaded(camera, params, variant) -> None:
    if camera is not None or params or variant is not None:
        raise InputError("camera, params and variant apply when loading; this scene is already loaded")


def _check_dict(params, variant) -> None:
    if params:
        raise InputError("params apply to Mitsuba XML files, not to a dict")
    if variant is not None:
        raise InputError("variant applies to glTF files (KHR_materials_variants), not to a dict")


def _numpy_media(d: dict) -> dict:
    """A heterogeneous medium's grid ("density", or "albedo" as a grid) given as a NumPy array indexed
    [z, y, x] (one channel) or [z, y, x, c] (c = 1 or 3 channels; docs/scene-format.md#media) becomes the
    format's flat "values" (x fastest, channels innermost) with its "resolution" [nx, ny, nz] and "channels"
    filled in; the dict is copied where it changes."""
    media = d.get("media")
    if not isinstance(media, dict):
        return d
    changed = {}
    for name, m in media.items():
        if not isinstance(m, dict):
            continue
        grids = {}
        for key in ("density", "albedo"):
            g = m.get(key)
            vals = g.get("values") if isinstance(g, dict) else None
            shape = getattr(vals, "shape", None)
            if shape is None or len(shape) not in (3, 4) or not hasattr(vals, "ravel"):
                continue
            ng = dict(g, values=vals.ravel().tolist())
            ng.setdefault("resolution", [int(shape[2]), int(shape[1]), int(shape[0])])
            if len(shape) == 4:
                ng.setdefault("channels", int(shape[3]))
            grids[key] = ng
        if grids:
            changed[name] = dict(m, **grids)
    return dict(d, media=dict(media, **changed)) if changed else d


def _json_default(o):
    # NumPy arrays and scalars anywhere in a scene dict (colours, positions, values) as JSON lists and numbers.
    if hasattr(o, "tolist"):
        return o.tolist()
    raise TypeError(f"Object of type {type(o).__name__} is not JSON serializable")


def _dict_text(d: dict) -> str:
    try:
        return json.dumps(_numpy_media(d), allow_nan=False, default=_json_default)
    except (TypeError, ValueError) as e:
        raise SceneError(f"<dict>: not representable as JSON: {e}") from None


def _warn(scene_or_warnings, stacklevel: int = 3) -> None:
    ws = scene_or_warnings.warnings if isinstance(scene_or_warnings, _native.Scene) else scene_or_warnings
    for w in ws:
        _warnings.warn(w, SceneWarning, stacklevel=stacklevel)


def load_dict(d: dict, camera: Optional[str] = None, base_dir: Union[str, os.PathLike, None] = None,
              width: Optional[int] = None, height: Optional[int] = None,
              filter: Optional[Union[str, dict]] = None, crop: Optional[Sequence[int]] = None) -> "_native.Scene":
    """Loads a scene given as a dict in caustica's JSON format (docs/scene-format.md). Errors
    name "<dict>" and the JSON path. Relative file names (meshes, textures) are resolved against
    `base_dir` (default: the current directory)."""
    if not isinstance(d, dict):
        raise InputError(f"load_dict: expected a dict, got {type(d).__name__}")
    s = _native.load_scene_json(_dict_text(d), "<dict>", os.fspath(base_dir) if base_dir is not None else "",
                                _camera(camera))
    _warn(s)
    return _override(s, width, height, filter, crop)


def load_scene(scene: Union[str, os.PathLike, dict, "_native.Scene"], width: Optional[int] = None,
               height: Optional[int] = None, filter: Optional[Union[str, dict]] = None, camera: Optional[str] = None,
               params: Optional[dict] = None, crop: Optional[Sequence[int]] = None,
               variant: Optional[str] = None) -> "_native.Scene":
    """Loads a built-in scene by name, a scene file (.json, .obj, .ply, .gltf, .glb, .xml), or a
    scene given as a dict in caustica's JSON format, and returns a Scene for caustica.render.

    camera: a named camera of the file (glTF, XML, JSON "cameras"); params: Mitsuba XML
    $name substitutions ({"spp": 64}); variant: a glTF file's material variant by name
    (KHR_materials_variants; scene.variants lists them, scene.variant is the one chosen).
    width/height/filter override the scene's (filter: a name, or a
    dict as the scene format's filter object, e.g. {"type": "mitchell", "B": 0, "C": 0.5}); width/height
    are the film's. crop=(x, y, w, h) renders only the film's pixels [x, x + w) x [y, y + h), into a w x h
    image that equals that part of the whole render (scene.crop, scene.film_size; (0, 0, 0, 0) removes a
    scene file's crop). Problems in
    the scene raise caustica.SceneError (an InputError); what was skipped or replaced is
    reported with warnings.warn (caustica.SceneWarning). scene.describe() gives counts, bounds, the
    camera's projection ("perspective", "thin lens", "orthographic") and its shutter (None unless it moves)."""
    if isinstance(scene, _native.Scene):
        _check_loaded(camera, params, variant)
        s = scene
    elif isinstance(scene, dict):
        _check_dict(params, variant)
        return load_dict(scene, camera=camera, width=width, height=height, filter=filter, crop=crop)
    elif isinstance(scene, (str, os.PathLike)):
        s = _native.load_scene(os.fspath(scene), _camera(camera), _params(params), _variant(variant))
        _warn(s)
    else:
        raise InputError(f"scene: expected a name, a path or a dict, got {type(scene).__name__}")
    return _override(s, width, height, filter, crop)


def _override(s, width, height, filter, crop=None):
    if crop is not None:
        try:
            x, y, w, h = (operator.index(v) for v in crop)
        except (TypeError, ValueError):
            raise InputError(f"crop: expected (x, y, width, height) in pixels, got {crop!r}") from None
    fw, fh = s.film_size
    new_w = _positive_int("width", width) if width is not None else fw
    new_h = _positive_int("height", height) if height is not None else fh
    if filter is not None and not isinstance(filter, dict) and filter not in FILTERS:
        raise InputError(f"unknown filter '{filter}' (allowed: {', '.join(FILTERS)})")
    old_crop = s.crop or (0, 0, 0, 0)
    # Any override that fails (a window that does not fit the film, a filter object with bad parameters) leaves
    # a loaded scene as it was: resolution and crop are put back; the filter is set last, only after the others
    # succeeded, and a failing filter sets nothing.
    try:
        if crop is not None:
            s.set_crop(0, 0, 0, 0)  # the new window is checked against the new film
        if (new_w, new_h) != (fw, fh):
            s.set_resolution(new_w, new_h)
        if crop is not None:
            s.set_crop(x, y, w, h)
        if isinstance(filter, dict):  # {"type": ..., parameters}: the scene format's filter object
            s.set_filter_json(json.dumps(filter))
        elif filter is not None:
            s.set_filter(filter)
    except InputError:
        s.set_crop(0, 0, 0, 0)
        s.set_resolution(fw, fh)
        s.set_crop(*old_crop)
        raise
    return s


def load_scene_desc(scene: Union[str, os.PathLike, dict], camera: Optional[str] = None,
                    params: Optional[dict] = None, variant: Optional[str] = None) -> "_native.SceneDesc":
    """Loads a scene's description without building it (no BVH): .describe(), .warnings,
    .cameras, .variants, .integrator_defaults, .write_json(path), .build() -> Scene."""
    if isinstance(scene, dict):
        _check_dict(params, variant)
        d = _native.load_json_desc(_dict_text(scene), "<dict>", "", _camera(camera))
    elif isinstance(scene, (str, os.PathLike)):
        d = _native.load_scene_desc(os.fspath(scene), _camera(camera), _params(params), _variant(variant))
    else:
        raise InputError(f"scene: expected a name, a path or a dict, got {type(scene).__name__}")
    _warn(d.warnings)
    return d


def describe(scene, camera: Optional[str] = None, params: Optional[dict] = None,
             variant: Optional[str] = None) -> dict:
    """Counts (shapes, meshes, triangles, spheres, materials, lights, area_lights, textures, media) and
    world-space bounds ((lo, hi)) of a scene (a name, a path, a dict or a loaded scene)."""
    if isinstance(scene, _native.Scene):
        _check_loaded(camera, params, variant)
        return scene.describe()
    return load_scene_desc(scene, camera=camera, params=params, variant=variant).describe()


def export_scene(scene: Union[str, os.PathLike, dict, "_native.Scene"], path: Union[str, os.PathLike],
                 camera: Optional[str] = None, params: Optional[dict] = None, variant: Optional[str] = None) -> None:
    """Writes a scene (a built-in name, a scene file, a dict or a loaded scene) as caustica JSON
    to `path`; textures go beside it as float EXR files (<stem>.tex<i>.exr). The file reads back
    to the same scene description, so it renders the same image (a glTF file's `variant`, when given, is
    the one exported: the JSON has that variant's materials only)."""
    out = os.fspath(path)
    if not out.lower().endswith(".json"):
        raise InputError(f"cannot write '{out}': scenes are exported as .json")
    d = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(d):
        raise InputError(f"cannot write '{out}': directory '{d}' does not exist")
    if isinstance(scene, _native.Scene):
        _check_loaded(camera, params, variant)
        scene.write_json(out)
    elif isinstance(scene, dict):
        _check_dict(params, variant)
        _warn(_native.export_scene_json(_dict_text(scene), "<dict>", "", out, _camera(camera)))
    elif isinstance(scene, (str, os.PathLike)):
        _warn(_native.export_scene(os.fspath(scene), out, _camera(camera), _params(params), _variant(variant)))
    else:
        raise InputError(f"scene: expected a name, a path or a dict, got {type(scene).__name__}")


def _positive_int(name: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v <= 0:
        raise InputError(f"{name} must be a positive integer, got {v!r}")
    return int(v)


@dataclass
class RenderResult:
    image: np.ndarray
    stats: dict = field(default_factory=dict)
    interrupted: bool = False
    strategies: dict = field(default_factory=dict)  # name -> (H, W, 3), with strategy_images=True


class RenderError(RuntimeError):
    """A render that failed midway (out of memory, a device error). `partial` is a RenderResult with the image
    of the passes completed before the failure (stats["passes"] of them; interrupted=True), or None when the
    first pass failed."""

    def __init__(self, message: str, partial: Optional[RenderResult] = None):
        super().__init__(message)
        self.partial = partial


def resolve_options(scene: "_native.Scene", integrator: Optional[str] = None, spp: Optional[int] = None,
                    time: Optional[float] = None, rr_depth: Optional[int] = None, sampler: Optional[str] = None,
                    photons: Optional[int] = None, radius: Optional[float] = None, alpha: Optional[float] = None,
                    k: Optional[int] = None, photon_sampling: Optional[str] = None,
                    light_sampler: Optional[str] = None, hide_emitters: Optional[bool] = None) -> dict:
    """Options given explicitly win; the rest come from the scene's integrator defaults (JSON
    "integrator"), then from caustica's own defaults (path, 16 spp, rr_depth 5, sobol, alpha 0.7
    (0.75 for bpm and vcm, Georgiev et al. 2012), k 50, photon_sampling "uniform"). spp and time go
    together: giving either ignores both of the scene's. The scene's photon_sampling applies to ppm,
    sppm and pppm only, its light_sampler to LIGHT_SAMPLER_INTEGRATORS only (default "power"); hide_emitters
    (default False) to every integrator."""
    dflt = scene.integrator_defaults
    if spp is None and time is None:
        spp, time = dflt.get("spp"), dflt.get("time")
    pick = lambda v, key, own: v if v is not None else dflt.get(key, own)
    integrator = pick(integrator, "integrator", "path")
    return dict(integrator=integrator, spp=spp, time=time,
                rr_depth=pick(rr_depth, "rr_depth", 5), sampler=pick(sampler, "sampler", "sobol"),
                photons=pick(photons, "photons", None), radius=pick(radius, "radius", None),
                alpha=pick(alpha, "alpha", 0.75 if integrator in ("bpm", "vcm") else 0.7), k=pick(k, "k", 50),
                photon_sampling=photon_sampling if photon_sampling is not None else
                dflt.get("photon_sampling", "uniform") if integrator in ("ppm", "sppm", "pppm") else "uniform",
                light_sampler=light_sampler if light_sampler is not None else
                dflt.get("light_sampler", "power") if integrator in LIGHT_SAMPLER_INTEGRATORS else "power",
                hide_emitters=pick(hide_emitters, "hide_emitters", False))


PHOTON_SAMPLINGS = ("uniform", "adaptive")
# Those that take light_sampler="bvh" (render.cpp's light_sampler_applies): their camera paths' light samples.
LIGHT_SAMPLER_INTEGRATORS = ("path", "restir", "pm", "ppm", "sppm", "pppm", "bdpt", "vcm", "upg")


# Variants compared as integrators of their own ("sppm+adaptive" is sppm with photon_sampling="adaptive"; several
# combine: "restir+nohistory+nospatial"): name -> (the options it sets, the integrators it applies to). Every
# variant runs on every driver (CPU, wavefront, CUDA).
VARIANTS = {
    "adaptive": ({"photon_sampling": "adaptive"}, ("ppm", "sppm", "pppm")),
    "nohistory": ({"restir_history": 0.0}, ("restir",)),
    "nospatial": ({"restir_neighbors": 0}, ("restir",)),
    "bvh": ({"light_sampler": "bvh"}, LIGHT_SAMPLER_INTEGRATORS),
}


def variant_names() -> list[str]:
    """Every integrator+variant name (for messages and help)."""
    return [f"{b}+{v}" for v, (_, bases) in VARIANTS.items() for b in bases]


def split_integrator_variant(name: str) -> tuple[str, dict]:
    """'sppm+adaptive' -> ('sppm', {'photon_sampling': 'adaptive'}); 'restir+nohistory+nospatial' -> ('restir',
    {'restir_history': 0.0, 'restir_neighbors': 0}); a plain name -> (name, {}). Comparisons (caustica.converge,
    caustica.study.realtime) take such variants as integrators of their own."""
    base, *variants = name.split("+")
    options = {}
    for variant in variants:
        if variant not in VARIANTS:
            raise InputError(f"unknown integrator variant '+{variant}' in '{name}' (allowed: "
                             f"{', '.join(variant_names())})")
        opts, bases = VARIANTS[variant]
        if base not in bases:
            raise InputError(f"'+{variant}' applies to {', '.join(bases)}, got '{name}'")
        options.update(opts)
    return base, options


def _photon_sampling(v) -> str:
    if v not in PHOTON_SAMPLINGS:
        raise InputError(f"unknown photon sampling '{v}' (allowed: {', '.join(PHOTON_SAMPLINGS)})")
    return v


def render_job(scene, integrator: Optional[str] = None, spp: Optional[int] = None, time: Optional[float] = None,
               seed: int = 0, threads: int = 0, max_depth: Optional[int] = None, rr_depth: Optional[int] = None,
               sampler: Optional[str] = None, accel: str = "auto",
               progress: Optional[Callable[[dict], Any]] = None, poll: float = 0.1,
               photons: Optional[int] = None, radius: Optional[float] = None, alpha: Optional[float] = None,
               pass_offset: int = 0, stochastic_hash: bool = False, k: Optional[int] = None,
               checkpoint: Optional[Callable[[np.ndarray], Any]] = None,
               checkpoint_interval: Optional[float] = None,
               target_error: Optional[float] = None, reference=None,
               target_noise: Optional[float] = None, strategy_images: bool = False,
               device: str = "cpu", wavefront: bool = False, compaction: bool = True,
               sort_materials: bool = False, cache_first_bounce: bool = False, jitter: bool = True,
               lanes: bool = True, photon_sampling: Optional[str] = None,
               restir_candidates: Optional[int] = None, restir_neighbors: Optional[int] = None,
               restir_radius: Optional[float] = None, restir_history: Optional[float] = None,
               light_sampler: Optional[str] = None, volume_radius: Optional[float] = None,
               hide_emitters: Optional[bool] = None, aov: Optional[str] = None) -> RenderResult:
    """Renders and returns a RenderResult; Ctrl-C (KeyboardInterrupt) stops the render and
    returns what was accumulated so far with interrupted=True.

    Photon integrators (sppm, ppm, pppm): `spp` counts passes; `photons` photon paths per
    pass (default one per pixel); `radius` the initial gather radius (default automatic,
    reported in stats["radius"]); `alpha` the radius reduction; `pass_offset` (pppm) renders
    passes [pass_offset, pass_offset + spp), which can be averaged with other ranges.
    ppm, pppm and sppm render participating media (volumetric photon mapping, on every driver; adaptive photon
    sampling too): `volume_radius` is the volume photons' initial radius (default automatic, reported in
    stats["volume_radius"]); pm does too, from the k nearest volume photons (Jensen & Christensen 1998). bpm and vcm
    merge at medium vertices too: there `volume_radius` is the ball's initial radius (default: for vcm one pixel
    footprint where camera paths first scatter in a medium, for bpm a ball of about 32 light vertices of a
    pass; reported in stats["volume_radius"]).
    `photon_sampling` (ppm, sppm, pppm, on every driver): "uniform" (default: the scene's, else uniform) or
    "adaptive", photon paths drawn by
    Markov chains on their visibility to the pass's visible points (Hachisuka & Jensen 2011); stats["adaptive"]
    then holds the visible fraction of uniform paths, the mutations' acceptance rate and the mutation size.
    `k` (pm): photons per k-nearest density estimate (default 50).
    restir (ReSTIR DI, Bitterli et al. 2020: the direct light at each pixel's first non-delta vertex resampled
    from light candidates and reused across passes and neighbouring pixels, unbiased; the rest path traced):
    `restir_candidates` light candidates per pixel and pass (default 32), `restir_neighbors` spatial neighbours
    (default 5, 0: no spatial reuse), `restir_radius` their radius in pixels (default 30), `restir_history`
    the temporal confidence cap in multiples of the candidates (default 20, 0: no temporal reuse); those not
    given come from the scene's (JSON "integrator": "restir_candidates", ...), then the defaults.
    `light_sampler` (path, restir, pm, ppm, sppm, pppm, bdpt, vcm, upg): how next-event estimation from camera
    paths (and restir's candidates) chooses a light: "power" (default: the scene's, else in proportion to its power) or
    "bvh" (by a light BVH's importance from the shading point, pbrt-v4's BVHLightSampler: far fewer wasted
    samples in scenes of many lights). Photons and light subpaths still leave the lights in proportion to power.
    `hide_emitters` (every integrator; default the scene's, else False): emitters seen directly from the camera
    (area lights and the environment at the end of the camera ray, through null boundaries) add nothing, as
    Mitsuba's hide_emitters; they still hide what is behind them, and their light, reflections and refractions
    stay.
    `aov` (path, every driver): instead of radiance, an output variable of the first surface each camera ray
    reaches (through null boundaries, ignoring media; 0 where it reaches none), averaged over the pixel like
    radiance: "depth" (distance along the ray), "position", "normal" (shading normal), "geo_normal", "uv" (u, v,
    0) or "albedo" (the material's main colour after textures and vertex colours), as Mitsuba's aov integrator.
    `checkpoint(image)` is called every `checkpoint_interval` seconds with the image so far.
    Stop on quality (checked after each pass; whichever of spp, time and a target comes first):
    `target_error` with `reference` (a path to an .exr/.pfm or an (H, W, 3) array) stops when
    relMSE(image, reference) <= target_error; `target_noise` (integrator path) stops when the
    relMSE estimated from the two half images (even and odd passes) <= target_noise. relMSE is
    the mean of (x - r)^2 / (r^2 + 0.01). stats["error"], stats["noise"] hold the last values
    checked and stats["target_reached"] says whether a target ended the render.
    `strategy_images` (light, bdpt, bpm, vcm): RenderResult.strategies maps "k{k}_s{s}_t{t}" (the
    connection strategy with s light and t camera vertices of paths of k <= 7 segments) and "merge_t{t}"
    (merges at camera vertex t) to MIS-weighted (H, W, 3) images that sum to the image over those paths.
    `device`: "cpu" (default), "cuda" or "cuda:N" (integrators path, sppm, ppm, pppm, pm, light, bdpt, bpm, vcm, upg, restir: the
    wavefront drivers on the GPU, traversing the portable BVH); a device that devices() does not list is an
    InputError saying why. `wavefront` (those integrators): run the GPU's wavefront driver on the CPU
    (strategy_images stays with the CPU driver). The wavefront path tracer's switches:
    `compaction` (stream compaction of finished paths, default on), `sort_materials` (sort each queue by
    material before shading), `cache_first_bounce` (reuse the first pass's camera-ray hits; needs
    jitter=False and a camera without lens or motion). `jitter=False` (path) traces every sample through the pixel centre.
    stats["device"] says where the passes ran. `accel` (CPU): "auto" (default) tests every triangle of a
    scene of at most 128 triangles (and 8 spheres), eight at a time with AVX2 ("small": on such scenes that
    is faster than Embree's per-query cost), and uses Embree otherwise; "embree", "small" (an InputError
    for a scene it does not take) and "bvh" (the portable BVH the GPU traverses) choose one; images agree
    to within the accelerators' rounding. stats["accel"] names the one used. `lanes` (path on the CPU): trace eight paths in lockstep with
    AVX2 arithmetic where the lane-parallel driver covers the scene (today: untextured `diffuse` surfaces,
    untextured triangle area lights); stats["lanes"] is 8 when it ran, 0 when paths were
    traced one at a time. The image is bit-identical either way; lanes=False is for comparisons.
    Options left as None come from the scene's integrator defaults (see resolve_options);
    stats["integrator"] names the integrator used. A render that fails midway (out of memory, a device error)
    raises RenderError, whose `partial` holds the image of the passes completed before (None if none)."""
    _check_device(device)
    scene = load_scene(scene)
    until_target = spp is None and time is None and (target_error is not None or target_noise is not None)
    o = resolve_options(scene, integrator, spp, time, rr_depth, sampler, photons, radius, alpha, k, photon_sampling,
                        light_sampler, hide_emitters)
    integrator, spp, time, rr_depth, sampler = o["integrator"], o["spp"], o["time"], o["rr_depth"], o["sampler"]
    if until_target:  # a target alone renders until it is met (not the scene's default spp)
        spp = time = None
    photons, radius, alpha, k = o["photons"], o["radius"], o["alpha"], o["k"]
    if integrator not in integrators():
        raise InputError(f"unknown integrator '{integrator}' (allowed: {', '.join(integrators())})")
    if sampler not in SAMPLERS:
        raise InputError(f"unknown sampler '{sampler}' (allowed: {', '.join(SAMPLERS)})")
    if accel not in ACCELS:
        raise InputError(f"unknown accelerator '{accel}' (allowed: {', '.join(ACCELS)})")
    spp_i = 0 if spp is None else _positive_int("spp", spp)
    if time is not None and (not isinstance(time, (int, float)) or not time > 0 or time != time):
        raise InputError(f"time must be a positive number of seconds, got {time!r}")
    if max_depth is None:
        md = -2
    elif max_depth == -1:
        md = -1
    else:
        md = _positive_int("max_depth", max_depth)
    if photons is not None:
        _positive_int("photons", photons)
    if radius is not None and (not isinstance(radius, (int, float)) or not radius > 0):
        raise InputError(f"radius must be a positive number, got {radius!r}")
    if not isinstance(alpha, (int, float)) or not 0 < alpha < 1:
        raise InputError(f"alpha must be in (0, 1), got {alpha!r}")
    if volume_radius is not None and (isinstance(volume_radius, bool) or not isinstance(volume_radius, (int, float))
                                      or not volume_radius > 0 or volume_radius == float("inf")):
        raise InputError(f"volume_radius must be a positive number, got {volume_radius!r}")
    for name, v in (("seed", seed), ("threads", threads), ("pass_offset", pass_offset)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
            raise InputError(f"{name} must be a non-negative integer, got {v!r}")
    targets = _targets(scene, target_error, reference, target_noise)
    restir = restir_job_options(scene, integrator, restir_candidates, restir_neighbors, restir_radius,
                                restir_history)
    job = _native.RenderJob(scene, integrator=integrator, spp=spp_i, time=float(time or 0.0), seed=int(seed),
                            threads=int(threads), max_depth=md, rr_depth=_positive_int("rr_depth", rr_depth),
                            sampler=sampler, accel=accel, photons=int(photons or 0), radius=float(radius or 0.0),
                            alpha=float(alpha), pass_offset=int(pass_offset), stochastic_hash=bool(stochastic_hash),
                            k=_positive_int("k", k), strategy_images=bool(strategy_images), device=device,
                            wavefront=bool(wavefront), compaction=bool(compaction),
                            sort_materials=bool(sort_materials), cache_first_bounce=bool(cache_first_bounce),
                            jitter=bool(jitter), lanes=bool(lanes), photon_sampling=_photon_sampling(o["photon_sampling"]),
                            light_sampler=_light_sampler(o["light_sampler"]),
                            volume_radius=float(volume_radius or 0.0),
                            hide_emitters=_boolean("hide_emitters", o["hide_emitters"]), aov=_aov(aov),
                            **restir, **targets)
    interrupted = False
    job.start()
    last_checkpoint = _time.monotonic()
    try:
        while not job.wait(poll):
            if progress is not None and progress(job.stats()) is False:
                job.cancel()
            if checkpoint is not None and checkpoint_interval and _time.monotonic() - last_checkpoint >= checkpoint_interval:
                if job.stats()["passes"] > 0:
                    checkpoint(job.image())
                last_checkpoint = _time.monotonic()
    except KeyboardInterrupt:
        interrupted = True
        job.cancel()
        while not job.wait(poll):
            pass
    except RuntimeError as e:  # the render thread failed; keep the passes it completed
        stats = dict(job.stats(), integrator=integrator)
        partial = RenderResult(image=job.image(), stats=stats, interrupted=True) if stats["passes"] > 0 else None
        raise RenderError(str(e), partial) from None
    stats = job.stats()
    stats["integrator"] = integrator
    if progress is not None and not interrupted:
        progress(stats)
    return RenderResult(image=job.image(), stats=stats, interrupted=interrupted,
                        strategies=job.strategy_images() if strategy_images else {})


LIGHT_SAMPLERS = ("power", "bvh")


AOVS = ("depth", "position", "normal", "geo_normal", "uv", "albedo")


def _aov(v) -> str:
    if v is None:
        return ""
    if v not in AOVS:
        raise InputError(f"unknown AOV {v!r} (allowed: {', '.join(AOVS)})")
    return v


def _boolean(name, v) -> bool:
    if not isinstance(v, (bool, np.bool_)):
        raise InputError(f"{name} must be True or False, got {v!r}")
    return bool(v)


def _light_sampler(v) -> str:
    if v not in LIGHT_SAMPLERS:
        raise InputError(f"unknown light sampler {v!r} (allowed: {', '.join(LIGHT_SAMPLERS)})")
    return v


def restir_job_options(scene, integrator, candidates=None, neighbors=None, radius=None, history=None) -> dict:
    """The restir_* keyword arguments of a native RenderJob: those given, then (for restir) the scene's (JSON
    "integrator": "restir_candidates", ...); checked."""
    given = dict(restir_candidates=candidates, restir_neighbors=neighbors, restir_radius=radius,
                 restir_history=history)
    if integrator == "restir":
        given = {key: scene.integrator_defaults.get(key) if v is None else v for key, v in given.items()}
    return _restir_options(integrator, *given.values())


def _restir_options(integrator, candidates, neighbors, radius, history) -> dict:
    """The restir options given (checked as numbers; the native job checks their ranges)."""
    given = {k: v for k, v in (("restir_candidates", candidates), ("restir_neighbors", neighbors),
                               ("restir_radius", radius), ("restir_history", history)) if v is not None}
    if given and integrator != "restir":
        verb = "applies" if len(given) == 1 else "apply"
        raise InputError(f"{', '.join(given)} {verb} to integrator 'restir', got '{integrator}'")
    for k in ("restir_candidates", "restir_neighbors"):
        if k in given:
            v = given[k]
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
                raise InputError(f"{k} must be a non-negative integer, got {v!r}")
            given[k] = int(v)
    for k in ("restir_radius", "restir_history"):
        if k in given:
            v = given[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise InputError(f"{k} must be a finite number, got {v!r}")
            given[k] = float(v)
    return given


def _targets(scene, target_error, reference, target_noise) -> dict:
    """Checks the stop-on-quality options and loads the reference as (H, W, 3) float32."""
    out = {}
    for name, v in (("target_error", target_error), ("target_noise", target_noise)):
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0 or v != v or v == float("inf"):
            raise InputError(f"{name} must be a positive number, got {v!r}")
        out[name] = float(v)
    if reference is not None and target_error is None:
        raise InputError("reference is used with target_error (the relMSE to stop at)")
    if target_error is not None:
        if reference is None:
            raise InputError("target_error needs a reference image (reference=path or array)")
        if isinstance(reference, (str, os.PathLike)):
            ref = read_image(reference)
        else:
            ref = np.asarray(reference, dtype=np.float32)
        if ref.ndim != 3 or ref.shape[2] != 3:
            raise InputError(f"the reference must be an (H, W, 3) image, got shape {ref.shape}")
        if ref.shape[:2] != (scene.height, scene.width):
            raise InputError(f"the reference is {ref.shape[1]}x{ref.shape[0]}, the render {scene.width}x{scene.height}")
        out["reference"] = np.ascontiguousarray(ref, dtype=np.float32)
    return out


def render(scene, integrator: Optional[str] = None, spp: Optional[int] = None, time: Optional[float] = None,
           seed: int = 0, threads: int = 0, max_depth: Optional[int] = None, rr_depth: Optional[int] = None,
           sampler: Optional[str] = None, accel: str = "auto",
           progress: Optional[Callable[[dict], Any]] = None, **photon_options) -> np.ndarray:
    """Renders `scene` (a name, a path, a dict or a loaded scene) and returns linear RGB
    radiance as a float32 NumPy array of shape (H, W, 3).

    spp: samples per pixel; time: seconds (render whole passes until spent); with neither,
    the scene's (JSON "integrator") or 16 spp. integrator, rr_depth, sampler and the photon
    options likewise default to the scene's, then to path / 5 / sobol. progress(stats) is called about ten times a second with a dict of counters
    (passes, target_passes, samples, rays, shadow_rays, seconds); returning False stops
    the render early. The GIL is released while rendering. Ctrl-C raises KeyboardInterrupt
    after stopping the render. Photon integrators take photons=, radius=, alpha=,
    pass_offset=, stochastic_hash=, photon_sampling=, and ppm/pppm/sppm in media volume_radius=; stop on quality: target_error= with reference=, and
    target_noise=; hide_emitters= (every integrator: emitters seen directly add nothing); aov= (path: "depth",
    "position", "normal", "geo_normal", "uv" or "albedo" instead of radiance) (see render_job)."""
    r = render_job(scene, integrator, spp, time, seed, threads, max_depth, rr_depth, sampler, accel, progress,
                   **photon_options)
    if r.interrupted:
        raise KeyboardInterrupt
    return r.image


def write_image(path: Union[str, os.PathLike], image: np.ndarray, exposure: float = 0.0) -> None:
    """Writes (H, W, 3) linear RGB as .exr, .pfm or .png (sRGB, scaled by 2^exposure),
    atomically (a temporary file renamed into place)."""
    a = np.ascontiguousarray(image, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise InputError(f"write_image: expected an (H, W, 3) array, got shape {a.shape}")
    _native.write_image(os.fspath(path), a, float(exposure))


def read_image(path: Union[str, os.PathLike]) -> np.ndarray:
    """Reads an .exr or .pfm image as a float32 (H, W, 3) array."""
    return _native.read_image(os.fspath(path))
