"""The `caustica` command line.

    caustica render [SCENE] -o OUT.{exr,pfm,png} [--integrator path] [--spp N | --time S] ...
    caustica info SCENE [--json]
    caustica export SCENE -o OUT.json
    caustica scenes
    caustica --version

SCENE is a built-in scene name or a scene file (.json, .obj, .ply, .gltf, .glb, .xml);
render, info and export take --camera NAME, --param NAME=VALUE (repeatable; Mitsuba
XML $NAME substitutions) and --variant NAME (a glTF file's KHR_materials_variants
variant). Bad input (an unknown scene, integrator or option, a bad number, an unknown
output format, an unwritable output path, a broken scene file) prints one line
to stderr and exits with status 2. Scene warnings are printed once each to stderr.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time as _time
import importlib
import warnings

from . import _api

EXIT_USAGE = 2


class UsageError(Exception):
    pass


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2, no usage dump
        raise UsageError(message)


def _number(name, parse, ok, expects):
    """An argparse type: parse, check, and on failure one line naming the option and what it expects."""
    def conv(s):
        try:
            v = parse(s)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} expects {expects}, got '{s}'")
        if not ok(v):
            raise argparse.ArgumentTypeError(f"{name} expects {expects}, got '{s}'")
        return v
    return conv


def _positive_int(name):
    return _number(name, int, lambda v: v > 0, "a positive integer")


def _nonneg_int(name):
    return _number(name, int, lambda v: v >= 0, "a non-negative integer")


def _seconds_named(name):
    return _number(name, float, lambda v: v > 0 and math.isfinite(v), "a positive number of seconds")


def _float(name):
    return _number(name, float, math.isfinite, "a finite number")


def _param(s):
    name, eq, value = s.partition("=")
    if not eq or not name:
        raise argparse.ArgumentTypeError(f"--param expects NAME=VALUE, got '{s}'")
    return name, value


def _scene_options(p, nargs="?"):
    p.add_argument("scene", nargs=nargs, default=None,
                   help=f"a built-in scene name or a scene file (.json, .obj, .ply, .gltf, .glb, .xml)"
                        + (f" (default: {_api.default_scene_name()})" if nargs == "?" else ""))
    p.add_argument("--camera", default=None, help="a named camera of the scene file (glTF, XML, JSON \"cameras\")")
    p.add_argument("--param", type=_param, action="append", default=[], metavar="NAME=VALUE",
                   help="Mitsuba XML $NAME substitution (repeatable)")
    p.add_argument("--variant", default=None, metavar="NAME",
                   help="a material variant of a glTF file (KHR_materials_variants; `caustica info` lists them)")


_depth = _number("--max-depth", int, lambda v: v == -1 or v > 0, "a positive integer or -1 (unlimited)")
_seconds = _seconds_named("--time")


COMMAND_MODULES = ("compare", "converge", "study")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="caustica", description="Physically based global illumination renderer.")
    p.add_argument("--version", action="version", version=f"caustica {_api.__version__}")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)
    r = sub.add_parser("render", help="render a scene to an image")
    _scene_options(r)
    r.add_argument("-o", "--output", action="append", default=None,
                   help="output image (.exr, .pfm or .png); may be given more than once (default: out.exr)")
    r.add_argument("--integrator", default=None,
                   help=f"one of: {', '.join(_api.integrators())} (default: the scene's, else path)")
    r.add_argument("--spp", "--passes", dest="spp", type=_positive_int("--spp"), default=None,
                   help="samples per pixel (default: the scene's, else 16 when no --time)")
    r.add_argument("--time", type=_seconds, default=None,
                   help="render whole passes until this many seconds are spent")
    r.add_argument("--width", type=_positive_int("--width"), default=None)
    r.add_argument("--height", type=_positive_int("--height"), default=None)
    r.add_argument("--crop", type=_nonneg_int("--crop"), nargs=4, default=None, metavar=("X", "Y", "W", "H"),
                   help="render only the film's pixels [X, X+W) x [Y, Y+H) into a WxH image, the same as that part of "
                        "the whole render (width/height stay the whole film's); 0 0 0 0 removes the scene's crop")
    r.add_argument("--seed", type=_nonneg_int("--seed"), default=0)
    r.add_argument("--threads", type=_nonneg_int("--threads"), default=0, help="0: all cores")
    r.add_argument("--max-depth", type=_depth, default=None,
                   help="longest path in segments, the camera segment being 1 (Mitsuba's count); -1: unlimited; "
                        "default: the scene's")
    r.add_argument("--rr-depth", type=_positive_int("--rr-depth"), default=None,
                   help="Russian roulette starts after this many segments (default: the scene's, else 5)")
    r.add_argument("--filter", default=None, help="pixel filter: box, tent, gaussian, mitchell, catmullrom or lanczos, with its default parameters "
                   "(default: the scene's; a scene file sets parameters)")
    r.add_argument("--sampler", default=None, help="sobol (Owen-scrambled) or independent (default: the scene's, else sobol)")
    r.add_argument("--accel", default="auto",
                   help="auto (default: small for scenes of at most 128 triangles, else embree), embree, small "
                        "(every triangle tested, eight at a time), or bvh (the portable BVH the GPU uses)")
    r.add_argument("--device", default="cpu",
                   help="cpu (default), cuda or cuda:N (path, sppm, ppm, pppm, pm, light, bdpt, bpm, vcm, upg, restir: "
                        "wavefronts on the GPU); `caustica devices` lists what this build and machine offer")
    r.add_argument("--wavefront", action="store_true",
                   help="path, sppm, ppm, pppm, pm, light, bdpt, bpm, vcm, upg, restir: run the GPU's wavefront driver on the "
                        "CPU (the same code as --device cuda)")
    r.add_argument("--no-compaction", action="store_true",
                   help="wavefront: keep finished paths in the queues (no stream compaction)")
    r.add_argument("--sort-materials", action="store_true",
                   help="wavefront: sort each queue by material before shading")
    r.add_argument("--cache-first-bounce", action="store_true",
                   help="wavefront: reuse the first pass's camera-ray hits (needs --no-jitter, a camera without lens or motion)")
    r.add_argument("--no-jitter", action="store_true",
                   help="path: every sample through the pixel centre (no anti-aliasing)")
    r.add_argument("--no-lanes", action="store_true",
                   help="path on the CPU: trace one path at a time instead of eight in lockstep (the same image; "
                        "for comparisons)")
    r.add_argument("--exposure", type=_float("--exposure"), default=0.0,
                   help="PNG only: scale by 2^exposure before sRGB encoding")
    r.add_argument("--photons", type=_positive_int("--photons"), default=None,
                   help="photon integrators: photon paths per pass; light, bdpt, bpm, vcm, upg: light subpaths per "
                        "pass (default: one per pixel)")
    r.add_argument("--radius", type=_float("--radius"), default=None,
                   help="photon integrators, bpm, vcm: initial gather/merge radius (default: automatic, printed)")
    r.add_argument("--volume-radius", type=_float("--volume-radius"), default=None,
                   help="ppm, pppm and sppm in scenes with participating media: the volume photons' initial radius "
                        "(default: automatic, printed); bpm and vcm: the volume merges' initial radius (default: "
                        "vcm a pixel footprint where camera paths scatter in a medium, bpm about 32 light vertices "
                        "of a pass, printed)")
    r.add_argument("--alpha", type=_float("--alpha"), default=None,
                   help="photon integrators, bpm, vcm: radius reduction, in (0, 1) (default: the scene's, else 0.7; "
                        "0.75 for bpm and vcm)")
    r.add_argument("--pass-offset", type=_nonneg_int("--pass-offset"), default=0,
                   help="pppm: first pass index (independent passes can be rendered apart and averaged)")
    r.add_argument("--k", type=_positive_int("--k"), default=None,
                   help="pm: photons per k-nearest-neighbour density estimate (default: the scene's, else 50)")
    r.add_argument("--strategy-images", metavar="DIR", default=None,
                   help="light, bdpt, bpm, vcm: also write one EXR per strategy to DIR (k{k}_s{s}_t{t}.exr: s light "
                        "and t camera vertices of paths of k <= 7 segments; merge_t{t}.exr), MIS-weighted")
    r.add_argument("--stochastic-hash", action="store_true",
                   help="photon maps keep one photon per hash cell (Hachisuka & Jensen 2010)")
    r.add_argument("--photon-sampling", default=None, metavar="{uniform,adaptive}",
                   help="ppm, sppm, pppm: how photon paths are drawn: uniform (independent paths) or adaptive "
                        "(Markov chains on the paths' visibility, Hachisuka & Jensen 2011) (default: the scene's, "
                        "else uniform)")
    r.add_argument("--light-sampler", default=None, metavar="{power,bvh}",
                   help="path, restir, pm, ppm, sppm, pppm, bdpt, vcm, upg: how next-event estimation from camera "
                        "paths (and "
                        "restir's candidates) chooses a light: power (in proportion to power) or bvh (a "
                        "light BVH's importance from the shading point; for scenes of many lights) (default: the "
                        "scene's, else power)")
    r.add_argument("--hide-emitters", action=argparse.BooleanOptionalAction, default=None,
                   help="every integrator: emitters seen directly from the camera (area lights, the environment) add "
                        "nothing; they still block what is behind them, and their light and reflections stay "
                        "(Mitsuba's hide_emitters) (default: the scene's, else shown)")
    r.add_argument("--aov", default=None, metavar="{depth,position,normal,geo_normal,uv,albedo}",
                   help="path: write an output variable of the first surface each camera ray reaches instead of "
                        "radiance (depth, position, normal, geo_normal, uv or albedo; 0 where the ray meets nothing)")
    r.add_argument("--restir-candidates", type=_positive_int("--restir-candidates"), default=None,
                   help="restir: light candidates per pixel and pass (default 32)")
    r.add_argument("--restir-neighbors", type=_nonneg_int("--restir-neighbors"), default=None,
                   help="restir: spatial neighbours per pixel and pass (default 5; 0: no spatial reuse)")
    r.add_argument("--restir-radius", type=_float("--restir-radius"), default=None,
                   help="restir: spatial reuse radius in pixels (default 30)")
    r.add_argument("--restir-history", type=_float("--restir-history"), default=None,
                   help="restir: temporal reuse's confidence cap, in multiples of the candidates (default 20; "
                        "0: no temporal reuse)")
    r.add_argument("--checkpoint", type=_seconds_named("--checkpoint"), default=None,
                   help="write the image so far every S seconds (atomically)")
    r.add_argument("--target-error", type=_float("--target-error"), default=None,
                   help="stop when relMSE against --reference is at or under this (checked after each pass)")
    r.add_argument("--reference", default=None, help="reference image (.exr or .pfm) for --target-error")
    r.add_argument("--target-noise", type=_float("--target-noise"), default=None,
                   help="path: stop when the relMSE estimated from two half images (even/odd passes) is at or "
                        "under this")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    i = sub.add_parser("info", help="describe a scene: counts of shapes, triangles, lights, materials; bounds")
    _scene_options(i, nargs=None)
    i.add_argument("--json", action="store_true", help="print the description as JSON")
    e = sub.add_parser("export", help="write a scene (built-in or file) as caustica JSON")
    _scene_options(e, nargs=None)
    e.add_argument("-o", "--output", required=True, help="the .json file to write (textures go beside it as .exr)")
    sub.add_parser("scenes", help="list the built-in scenes")
    sub.add_parser("devices", help="list the devices this build can render on")
    # Commands in their own modules (caustica/commands/<name>.py): each defines
    # add_parser(sub) -> the subparser and run(args) -> exit status.
    for name in COMMAND_MODULES:
        mod = importlib.import_module(f"caustica.commands.{name}")
        sp = mod.add_parser(sub)
        if sp is not None:
            sp.set_defaults(_module=mod)
    return p


def _check_choice(name, value, allowed):
    if value not in allowed:
        raise _api.InputError(f"unknown {name} '{value}' (allowed: {', '.join(allowed)})")


def _check_output(path: str):
    if not _api._native.is_supported_image_extension(path):
        ext = os.path.splitext(path)[1] or "(none)"
        raise _api.InputError(f"cannot write '{path}': unknown output format '{ext}' (allowed: .exr, .pfm, .png)")
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        raise _api.InputError(f"cannot write '{path}': directory '{d}' does not exist")
    if not os.access(d, os.W_OK):
        raise _api.InputError(f"cannot write '{path}': directory '{d}' is not writable")
    if os.path.isdir(path):
        raise _api.InputError(f"cannot write '{path}': it is a directory")


class _Progress:
    """A tqdm bar over passes (or seconds for a time budget) with samples/s."""

    def __init__(self, spp, seconds, enabled):
        self.bar = None
        self.spp, self.seconds, self.enabled = spp, seconds, enabled
        self.by_time = spp is None and seconds is not None
        self.t0 = _time.monotonic()

    def _open(self):
        # Opened at the first report, i.e. once the render has started: options the renderer rejects
        # give their one error line without a bar before it.
        from tqdm import tqdm
        if self.by_time:
            self.bar = tqdm(total=round(self.seconds, 1), unit="s", desc="rendering", dynamic_ncols=True,
                            bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s [{elapsed}<{remaining}{postfix}]")
        else:
            self.bar = tqdm(total=self.spp, unit="spp", desc="rendering", dynamic_ncols=True)

    def __call__(self, st):
        if not self.enabled:
            return True
        if self.bar is None:
            self._open()
        elapsed = _time.monotonic() - self.t0
        n = min(elapsed, self.bar.total) if self.by_time else st["passes"]
        self.bar.n = n
        rate = st["samples"] / elapsed if elapsed > 0 else 0.0
        post = f"{rate / 1e6:.2f} M samples/s"
        if st.get("photons"):
            post = f"{st['passes'] / elapsed if elapsed > 0 else 0:.2f} passes/s, {st['photons'] / elapsed / 1e6:.2f} M photons/s"
        if st.get("error") is not None:
            post += f", relMSE {st['error']:.3g}"
        if st.get("noise") is not None:
            post += f", noise {st['noise']:.3g}"
        self.bar.set_postfix_str(post, refresh=False)
        self.bar.refresh()
        return True

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _load(a, **kw):
    """Loads a.scene with --camera/--param/--variant; each scene warning goes to stderr once."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", _api.SceneWarning)
        scene = _api.load_scene(a.scene or _api.default_scene_name(), camera=a.camera,
                                params=dict(a.param) or None, variant=a.variant, **kw)
    _print_warnings(caught)
    return scene


def _print_warnings(caught):
    seen = set()
    for w in caught:
        msg = str(w.message)
        if issubclass(w.category, _api.SceneWarning) and msg not in seen:
            seen.add(msg)
            print(f"caustica: warning: {msg}", file=sys.stderr)
        elif not issubclass(w.category, _api.SceneWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def cmd_render(a) -> int:
    outputs = a.output or ["out.exr"]
    for o in outputs:
        _check_output(o)
    if a.integrator is not None:
        _check_choice("integrator", a.integrator, _api.integrators())
    if a.sampler is not None:
        _check_choice("sampler", a.sampler, _api.SAMPLERS)
    _check_choice("accelerator", a.accel, _api.ACCELS)
    if a.photon_sampling is not None:
        _check_choice("photon sampling", a.photon_sampling, _api.PHOTON_SAMPLINGS)
    if a.light_sampler is not None:
        _check_choice("light sampler", a.light_sampler, _api.LIGHT_SAMPLERS)
    if a.aov is not None:
        _check_choice("AOV", a.aov, _api.AOVS)
    _api._check_device(a.device)
    if a.filter is not None:
        _check_choice("filter", a.filter, _api.FILTERS)
    if a.radius is not None and not a.radius > 0:
        raise _api.InputError(f"--radius expects a positive number, got '{a.radius}'")
    if a.alpha is not None and not 0 < a.alpha < 1:
        raise _api.InputError(f"--alpha expects a number in (0, 1), got '{a.alpha}'")
    if a.volume_radius is not None and not 0 < a.volume_radius < float("inf"):
        raise _api.InputError(f"--volume-radius expects a positive number, got '{a.volume_radius}'")
    if a.strategy_images is not None and not os.path.isdir(a.strategy_images):
        raise _api.InputError(f"--strategy-images: '{a.strategy_images}' is not a directory")
    scene = _load(a, width=a.width, height=a.height, filter=a.filter, crop=a.crop)
    o = _api.resolve_options(scene, a.integrator, a.spp, a.time, a.rr_depth, a.sampler, a.photons, a.radius,
                             a.alpha, a.k)
    integrator, spp, seconds = o["integrator"], o["spp"], o["time"]
    restir_flags = [f for f, v in (("--restir-candidates", a.restir_candidates), ("--restir-neighbors", a.restir_neighbors),
                                   ("--restir-radius", a.restir_radius), ("--restir-history", a.restir_history))
                    if v is not None]
    if restir_flags and integrator != "restir":
        verb = "applies" if len(restir_flags) == 1 else "apply"
        raise _api.InputError(f"{', '.join(restir_flags)} {verb} to integrator 'restir', got '{integrator}'")
    target = a.target_error is not None or a.target_noise is not None
    if a.reference is not None and a.target_error is None:
        raise _api.InputError("--reference goes with --target-error (the relMSE to stop at)")
    if a.target_error is not None and a.reference is None:
        raise _api.InputError("--target-error needs --reference (an image to measure the error against)")
    if target and a.spp is None and a.time is None:
        spp = seconds = None  # render until the target is met
    elif spp is None and seconds is None:
        spp = 16
    prog = _Progress(spp, seconds, enabled=not a.quiet)

    def write_all(image):
        for o in outputs:
            _api.write_image(o, image, exposure=a.exposure)

    failed = None
    try:
        res = _api.render_job(scene, integrator=integrator, spp=spp, time=seconds, seed=a.seed,
                              threads=a.threads, max_depth=a.max_depth, rr_depth=o["rr_depth"],
                              sampler=o["sampler"], accel=a.accel, progress=prog, photons=o["photons"],
                              radius=o["radius"], volume_radius=a.volume_radius, alpha=o["alpha"],
                              pass_offset=a.pass_offset,
                              stochastic_hash=a.stochastic_hash, k=o["k"], checkpoint=write_all if a.checkpoint else None,
                              checkpoint_interval=a.checkpoint, target_error=a.target_error,
                              reference=a.reference, target_noise=a.target_noise,
                              strategy_images=a.strategy_images is not None, device=a.device,
                              wavefront=a.wavefront, compaction=not a.no_compaction,
                              sort_materials=a.sort_materials, cache_first_bounce=a.cache_first_bounce,
                              jitter=not a.no_jitter, lanes=not a.no_lanes, photon_sampling=a.photon_sampling,
                              restir_candidates=a.restir_candidates, restir_neighbors=a.restir_neighbors,
                              restir_radius=a.restir_radius, restir_history=a.restir_history,
                              light_sampler=a.light_sampler, hide_emitters=a.hide_emitters, aov=a.aov)
    except _api.RenderError as e:
        failed = e
    finally:
        prog.close()
    if failed is not None:  # keep what the render had (as an interrupted render does), then fail
        if failed.partial is None:
            raise failed
        write_all(failed.partial.image)
        n = failed.partial.stats["passes"]
        print(f"caustica: error: the render failed after {n} pass{'' if n == 1 else 'es'}: {failed}; wrote the image "
              f"of those passes to {', '.join(outputs)}", file=sys.stderr)
        return 1
    st = res.stats
    write_all(res.image)
    for name, img in res.strategies.items():
        _api.write_image(os.path.join(a.strategy_images, name + ".exr"), img)
    secs = max(st["seconds"], 1e-9)
    where = "" if st.get("device", "cpu") == "cpu" else f" on {st['device']}"
    if integrator in ("light", "bdpt", "bpm", "vcm", "upg"):
        # Bidirectional: one light path (and, except for light, one eye path) per pixel per pass.
        msg = (f"{scene.name}: {integrator}, {st['passes']} passes, {scene.width}x{scene.height}, "
               f"{st['seconds']:.2f} s, {st['passes'] / secs:.2f} passes/s, {st['photons']} light paths "
               f"({st['photons'] / secs / 1e6:.2f} M/s)")
        if integrator in ("bpm", "vcm", "upg"):
            msg += f", initial radius {st['radius']:.4g}"
        msg += f" -> {', '.join(outputs)}"
    elif integrator == "restir":
        msg = (f"{scene.name}: restir, {st['passes']} passes, {scene.width}x{scene.height}, {st['seconds']:.2f} s, "
               f"{st['passes'] / secs:.2f} passes/s, {(st['rays'] + st['shadow_rays']) / secs / 1e6:.2f} M rays/s "
               f"-> {', '.join(outputs)}")
    elif st.get("photons") or integrator != "path":
        msg = (f"{scene.name}: {integrator}{where}, {st['passes']} passes, {scene.width}x{scene.height}, "
               f"{st['seconds']:.2f} s, {st['passes'] / secs:.2f} passes/s, {st['photons']} photon paths "
               f"({st['photons'] / secs / 1e6:.2f} M photons/s), ")
        # pm's estimates take the k nearest photons (its maps are built once); the others gather in a radius.
        msg += f"{o['k']} nearest photons per estimate" if integrator == "pm" else f"initial radius {st['radius']:.4g}"
        if st.get("volume_radius"):
            msg += f", volume radius {st['volume_radius']:.4g}"
        if st.get("adaptive"):
            ad = st["adaptive"]
            msg += (f", adaptive: {100 * ad['visible_fraction']:.3g}% of uniform paths visible, acceptance "
                    f"{ad['acceptance']:.3f}, mutation size {ad['mutation_size']:.3g}")
        msg += f" -> {', '.join(outputs)}"
    else:
        msg = (f"{scene.name}: {st['passes']} spp{where}, {scene.width}x{scene.height}, {st['seconds']:.2f} s, "
               f"{st['samples'] / secs / 1e6:.2f} M samples/s, "
               f"{(st['rays'] + st['shadow_rays']) / secs / 1e6:.2f} M rays/s -> {', '.join(outputs)}")
    if st.get("error") is not None:
        msg += f"; relMSE vs reference {st['error']:.4g}"
    if st.get("noise") is not None:
        msg += f"; estimated relMSE from noise {st['noise']:.4g}"
    if target:
        msg += "; target reached" if st.get("target_reached") else "; target not reached"
    if res.interrupted:
        msg = "interrupted: wrote the image accumulated so far. " + msg
    print(msg, file=sys.stderr)
    return 130 if res.interrupted else 0


def cmd_info(a) -> int:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", _api.SceneWarning)
        scene = _api.load_scene_desc(a.scene, camera=a.camera, params=dict(a.param) or None, variant=a.variant)
    _print_warnings(caught)
    d = scene.describe()
    if a.json:
        clip = None if d["clip"] is None else [v if math.isfinite(v) else None for v in d["clip"]]
        d = dict(d, bounds=[list(d["bounds"][0]), list(d["bounds"][1])], width=scene.width, height=scene.height,
                 film_size=list(scene.film_size), crop=None if d["crop"] is None else list(d["crop"]), clip=clip,
                 camera=scene.camera, cameras=list(scene.cameras), variant=scene.variant or None,
                 variants=list(scene.variants), integrator=dict(scene.integrator_defaults))
        print(json.dumps(d, indent=2))
        return 0
    lo, hi = d["bounds"]
    fmt = lambda v: "[" + ", ".join(f"{x:.6g}" for x in v) + "]"
    print(f"name:        {d['name']}")
    fp = ", ".join(f"{k} {v:.4g}" for k, v in scene.filter_parameters.items())
    crop = ("" if d["crop"] is None else
            f" (crop at {d['crop'][0]}, {d['crop'][1]} of the {scene.film_size[0]}x{scene.film_size[1]} film)")
    print(f"image:       {scene.width}x{scene.height}{crop}, {scene.filter} filter ({fp})"
          + (f", camera '{scene.camera}'" if scene.camera else ""))
    if scene.cameras:
        print(f"cameras:     {', '.join(scene.cameras)}")
    if scene.variants:
        print(f"variants:    {', '.join(scene.variants)}"
              + (f" (rendering '{scene.variant}')" if scene.variant else " (none chosen: --variant NAME)"))
    print(f"projection:  {d['projection']}" + ("" if d["shutter"] is None else
          f", moving camera (motion blur, shutter {d['shutter'][0]:g} to {d['shutter'][1]:g})")
          + ("" if d["clip"] is None else f", clipped to depths {d['clip'][0]:g} to {d['clip'][1]:g}"))
    for key in ("shapes", "meshes", "triangles", "spheres", "materials", "lights", "area_lights", "textures", "media"):
        kinds = [f"{d[k + '_media']} {k}" for k in ("heterogeneous", "emissive") if key == "media" and d[k + "_media"]]
        print(f"{key + ':':12s} {d[key]}" + (f" ({', '.join(kinds)})" if kinds else ""))
    print(f"bounds:      {fmt(lo)} .. {fmt(hi)}")
    defaults = dict(scene.integrator_defaults)
    if defaults:
        print("integrator:  " + ", ".join(f"{k} {v}" for k, v in defaults.items()))
    return 0


def cmd_export(a) -> int:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", _api.SceneWarning)
        _api.export_scene(a.scene, a.output, camera=a.camera, params=dict(a.param) or None, variant=a.variant)
    _print_warnings(caught)
    print(f"{a.scene} -> {a.output}", file=sys.stderr)
    return 0


def cmd_devices(a) -> int:
    for d in _api.devices():
        print(f"{d['name']:6s} {d['description']}")
    devs, why = _api.cuda_status()
    if not devs:
        print(f"cuda   not available: {why}")
    return 0


def cmd_scenes(a) -> int:
    for name, desc in _api.builtin_scenes():
        print(f"{name:22s} {desc}")
    return 0


def main(argv=None) -> int:
    parser = build_parser()
    try:
        a = parser.parse_args(argv)
        if a.command is None:
            parser.print_help(sys.stderr)
            return EXIT_USAGE
        if a.command == "render":
            return cmd_render(a)
        if a.command == "info":
            return cmd_info(a)
        if a.command == "export":
            return cmd_export(a)
        if a.command == "devices":
            return cmd_devices(a)
        if getattr(a, "_module", None) is not None:
            return a._module.run(a)
        return cmd_scenes(a)
    except (UsageError, _api.InputError) as e:
        print(f"caustica: error: {e}", file=sys.stderr)
        return EXIT_USAGE
    except (MemoryError, RuntimeError) as e:  # from the native render (out of memory, a device error)
        print(f"caustica: error: the render failed: {e or type(e).__name__}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("caustica: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader of stdout went away (`caustica info x | head`): stop quietly, as other command-line tools
        # do; stdout is pointed at /dev/null so that Python's final flush does not fail again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    sys.exit(main())
