"""The `caustica` command line.

    caustica render [SCENE] -o OUT.{exr,pfm,png} [--integrator path] [--spp N | --time S] ...
    caustica scenes
    caustica --version

Bad input (an unknown scene, integrator or option, a bad number, an unknown output
format, an unwritable output path) prints one line to stderr and exits with status 2.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time as _time

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


_depth = _number("--max-depth", int, lambda v: v == -1 or v > 0, "a positive integer or -1 (unlimited)")
_seconds = _seconds_named("--time")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="caustica", description="Physically based global illumination renderer.")
    p.add_argument("--version", action="version", version=f"caustica {_api.__version__}")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)
    r = sub.add_parser("render", help="render a scene to an image")
    r.add_argument("scene", nargs="?", default=None,
                   help=f"a built-in scene name or a scene file (default: {_api.default_scene_name()})")
    r.add_argument("-o", "--output", action="append", default=None,
                   help="output image (.exr, .pfm or .png); may be given more than once (default: out.exr)")
    r.add_argument("--integrator", default="path", help=f"one of: {', '.join(_api.integrators())}")
    r.add_argument("--spp", "--passes", dest="spp", type=_positive_int("--spp"), default=None,
                   help="samples per pixel (default: 16 when no --time)")
    r.add_argument("--time", type=_seconds, default=None,
                   help="render whole passes until this many seconds are spent")
    r.add_argument("--width", type=_positive_int("--width"), default=None)
    r.add_argument("--height", type=_positive_int("--height"), default=None)
    r.add_argument("--seed", type=_nonneg_int("--seed"), default=0)
    r.add_argument("--threads", type=_nonneg_int("--threads"), default=0, help="0: all cores")
    r.add_argument("--max-depth", type=_depth, default=None,
                   help="longest path in segments, the camera segment being 1 (Mitsuba's count); -1: unlimited; "
                        "default: the scene's")
    r.add_argument("--rr-depth", type=_positive_int("--rr-depth"), default=5,
                   help="Russian roulette starts after this many segments")
    r.add_argument("--filter", default=None, help="pixel filter: box, tent or gaussian (default: the scene's)")
    r.add_argument("--sampler", default="sobol", help="sobol (Owen-scrambled) or independent")
    r.add_argument("--accel", default="embree", help="embree, or bvh (the portable BVH the GPU uses)")
    r.add_argument("--exposure", type=_float("--exposure"), default=0.0,
                   help="PNG only: scale by 2^exposure before sRGB encoding")
    r.add_argument("--photons", type=_positive_int("--photons"), default=None,
                   help="photon integrators: photon paths per pass (default: one per pixel)")
    r.add_argument("--radius", type=_float("--radius"), default=None,
                   help="photon integrators: initial gather radius (default: automatic, printed)")
    r.add_argument("--alpha", type=_float("--alpha"), default=0.7, help="photon integrators: radius reduction, in (0, 1)")
    r.add_argument("--pass-offset", type=_nonneg_int("--pass-offset"), default=0,
                   help="pppm: first pass index (independent passes can be rendered apart and averaged)")
    r.add_argument("--k", type=_positive_int("--k"), default=50,
                   help="pm: photons per k-nearest-neighbour density estimate")
    r.add_argument("--stochastic-hash", action="store_true",
                   help="photon maps keep one photon per hash cell (Hachisuka & Jensen 2010)")
    r.add_argument("--checkpoint", type=_seconds_named("--checkpoint"), default=None,
                   help="write the image so far every S seconds (atomically)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    sub.add_parser("scenes", help="list the built-in scenes")
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
        self.by_time = spp is None and seconds is not None
        if not enabled:
            return
        from tqdm import tqdm
        if self.by_time:
            self.bar = tqdm(total=round(seconds, 1), unit="s", desc="rendering", dynamic_ncols=True,
                            bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s [{elapsed}<{remaining}{postfix}]")
        else:
            self.bar = tqdm(total=spp, unit="spp", desc="rendering", dynamic_ncols=True)
        self.t0 = _time.monotonic()

    def __call__(self, st):
        if self.bar is None:
            return True
        elapsed = _time.monotonic() - self.t0
        n = min(elapsed, self.bar.total) if self.by_time else st["passes"]
        self.bar.n = n
        rate = st["samples"] / elapsed if elapsed > 0 else 0.0
        post = f"{rate / 1e6:.2f} M samples/s"
        if st.get("photons"):
            post = f"{st['passes'] / elapsed if elapsed > 0 else 0:.2f} passes/s, {st['photons'] / elapsed / 1e6:.2f} M photons/s"
        self.bar.set_postfix_str(post, refresh=False)
        self.bar.refresh()
        return True

    def close(self):
        if self.bar is not None:
            self.bar.close()


def cmd_render(a) -> int:
    outputs = a.output or ["out.exr"]
    for o in outputs:
        _check_output(o)
    _check_choice("integrator", a.integrator, _api.integrators())
    _check_choice("sampler", a.sampler, _api.SAMPLERS)
    _check_choice("accelerator", a.accel, _api.ACCELS)
    if a.filter is not None:
        _check_choice("filter", a.filter, _api.FILTERS)
    scene_name = a.scene or _api.default_scene_name()
    scene = _api.load_scene(scene_name, width=a.width, height=a.height, filter=a.filter)
    spp = a.spp if (a.spp is not None or a.time is not None) else 16
    if a.radius is not None and not a.radius > 0:
        raise _api.InputError(f"--radius expects a positive number, got '{a.radius}'")
    if not 0 < a.alpha < 1:
        raise _api.InputError(f"--alpha expects a number in (0, 1), got '{a.alpha}'")
    prog = _Progress(spp, a.time, enabled=not a.quiet)

    def write_all(image):
        for o in outputs:
            _api.write_image(o, image, exposure=a.exposure)

    try:
        res = _api.render_job(scene, integrator=a.integrator, spp=spp, time=a.time, seed=a.seed,
                              threads=a.threads, max_depth=a.max_depth, rr_depth=a.rr_depth,
                              sampler=a.sampler, accel=a.accel, progress=prog, photons=a.photons,
                              radius=a.radius, alpha=a.alpha, pass_offset=a.pass_offset,
                              stochastic_hash=a.stochastic_hash, k=a.k, checkpoint=write_all if a.checkpoint else None,
                              checkpoint_interval=a.checkpoint)
    finally:
        prog.close()
    st = res.stats
    write_all(res.image)
    secs = max(st["seconds"], 1e-9)
    if st.get("photons") or a.integrator != "path":
        msg = (f"{scene.name}: {a.integrator}, {st['passes']} passes, {scene.width}x{scene.height}, "
               f"{st['seconds']:.2f} s, {st['passes'] / secs:.2f} passes/s, {st['photons']} photon paths "
               f"({st['photons'] / secs / 1e6:.2f} M photons/s), initial radius {st['radius']:.4g} "
               f"-> {', '.join(outputs)}")
    else:
        msg = (f"{scene.name}: {st['passes']} spp, {scene.width}x{scene.height}, {st['seconds']:.2f} s, "
               f"{st['samples'] / secs / 1e6:.2f} M samples/s, "
               f"{(st['rays'] + st['shadow_rays']) / secs / 1e6:.2f} M rays/s -> {', '.join(outputs)}")
    if res.interrupted:
        msg = "interrupted: wrote the image accumulated so far. " + msg
    print(msg, file=sys.stderr)
    return 130 if res.interrupted else 0


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
        return cmd_scenes(a)
    except (UsageError, _api.InputError) as e:
        print(f"caustica: error: {e}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("caustica: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
