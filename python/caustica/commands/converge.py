"""`caustica converge`: error against time for several integrators at equal wall-clock time.

    caustica converge SCENE --make-reference --time 3600 -o REF.exr [--integrator path] [--spp N]
    caustica converge SCENE --integrators path,sppm --time 60 --reference REF.exr
                      [--metrics relmse,flip] [--out DIR] [--seed K] [--width W --height H]
                      [--checkpoints N | --at 1,2,5,10] [--crop X,Y,W,H] [--region X,Y,W,H]

Writes DIR/converge.jsonl, DIR/<metric>.png/.svg, DIR/grid.png and the final images and
error maps (see caustica.converge and docs/convergence.md). Bad input: one line, exit 2.
"""
from __future__ import annotations

import argparse
import importlib
import math
import os
import sys
import warnings

from .. import _api


from ..cli import _number as _num  # noqa: E402  (one argparse type factory for every command)


def _list(name, parse, ok, expects, n=None):
    def conv(s):
        try:
            v = [parse(x) for x in s.split(",") if x.strip()]
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} expects {expects}, got '{s}'") from None
        if not v or not all(ok(x) for x in v) or (n is not None and len(v) != n):
            raise argparse.ArgumentTypeError(f"{name} expects {expects}, got '{s}'")
        return v
    return conv


_pos_int = lambda name: _num(name, int, lambda v: v > 0, "a positive integer")
_seconds = _num("--time", float, lambda v: v > 0 and math.isfinite(v), "a positive number of seconds")


def _param(s):
    name, sep, value = s.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"--param expects NAME=VALUE, got '{s}'")
    return name, value


def add_parser(sub):
    p = sub.add_parser("converge", help="error against time for several integrators at equal time; "
                                        "or render a reference (--make-reference)")
    p.add_argument("scene", help="a built-in scene name or a scene file")
    p.add_argument("--integrators", default="path,sppm",
                   help=f"comma-separated, of: {', '.join(_api.integrators())}, and the variants "
                        f"{', '.join(_api.variant_names())} (default: path,sppm)")
    p.add_argument("--time", type=_seconds, default=None,
                   help="seconds per integrator (default 60); with --make-reference, the reference's budget")
    p.add_argument("--reference", default=None, help="the reference image (.exr/.pfm; its .json sidecar is read)")
    p.add_argument("--metrics", default="relmse,flip", help="comma-separated metrics (default: relmse,flip)")
    p.add_argument("--out", default=None, help="output directory (default: converge-<scene>)")
    p.add_argument("--seed", type=_num("--seed", int, lambda v: v >= 0, "a non-negative integer"), default=None,
                   help="seed of every run (default 0; with --make-reference 1000003)")
    p.add_argument("--width", type=_pos_int("--width"), default=None)
    p.add_argument("--height", type=_pos_int("--height"), default=None)
    p.add_argument("--camera", default=None, help="a named camera of the scene file")
    p.add_argument("--variant", default=None, metavar="NAME", help="a material variant of a glTF file")
    p.add_argument("--param", type=_param, action="append", default=[], metavar="NAME=VALUE",
                   help="Mitsuba XML $NAME substitution (repeatable)")
    p.add_argument("--checkpoints", type=_pos_int("--checkpoints"), default=None,
                   help="checkpoints per decade of time, from 0.5 s (default 8)")
    p.add_argument("--at", type=_list("--at", float, lambda v: v > 0 and math.isfinite(v),
                                      "comma-separated positive seconds"), default=None,
                   help="checkpoint times in seconds instead (e.g. 1,2,5,10)")
    p.add_argument("--crop", type=_list("--crop", int, lambda v: v >= 0, "X,Y,W,H in pixels", n=4), default=None,
                   help="the equal-time grid's crop, X,Y,W,H (default: the whole image)")
    p.add_argument("--region", type=_list("--region", int, lambda v: v >= 0, "X,Y,W,H in pixels", n=4), default=None,
                   help="render and measure only these pixels of the film, X,Y,W,H (also --make-reference; "
                        "default: the reference's region, if it has one)")
    p.add_argument("--threads", type=_num("--threads", int, lambda v: v >= 0, "a non-negative integer"),
                   default=None, help="0: all cores")
    p.add_argument("--max-depth", type=_num("--max-depth", int, lambda v: v == -1 or v > 0,
                                            "a positive integer or -1 (unlimited)"), default=None)
    p.add_argument("--sampler", default=None, help="sobol or independent (default: the scene's, else sobol)")
    p.add_argument("--photons", type=_pos_int("--photons"), default=None, help="photon paths per pass")
    p.add_argument("--make-reference", action="store_true", help="render a reference to -o instead")
    p.add_argument("-o", "--output", default=None, help="--make-reference: the reference to write (.exr)")
    p.add_argument("--integrator", default="path", help="--make-reference: its integrator (default: path)")
    p.add_argument("--spp", type=_pos_int("--spp"), default=None, help="--make-reference: samples (passes) "
                                                                        "instead of --time")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    return p


def _say(quiet, msg):
    if not quiet:
        print(msg, file=sys.stderr, flush=True)


def run(a) -> int:
    cv = importlib.import_module("caustica.converge")  # the module (the package attribute is the function)
    opts = {k: v for k, v in (("threads", a.threads), ("max_depth", a.max_depth), ("sampler", a.sampler),
                              ("photons", a.photons)) if v is not None}
    scene_kw = dict(width=a.width, height=a.height, camera=a.camera, params=dict(a.param) or None,
                    variant=a.variant, region=a.region)
    if a.make_reference:
        if a.output is None:
            raise _api.InputError("--make-reference needs -o REF.exr")
        if a.time is None and a.spp is None:
            raise _api.InputError("--make-reference needs --time SECONDS or --spp N")
        if a.integrator not in _api.integrators():
            raise _api.InputError(f"unknown integrator '{a.integrator}' (allowed: {', '.join(_api.integrators())})")
        state = {"next": 0.0}

        def prog(st):
            if st["seconds"] >= state["next"]:
                state["next"] = st["seconds"] + max(1.0, (a.time or 0) / 20)
                _say(a.quiet, f"reference: {st['seconds']:.1f} s, {st['passes']} passes")
            return True

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", _api.SceneWarning)
            meta = cv.make_reference(a.scene, a.output, integrator=a.integrator, time=a.time, spp=a.spp,
                                     seed=a.seed if a.seed is not None else cv.REFERENCE_SEED, progress=prog,
                                     **scene_kw, **opts)
        print(f"{a.scene}: reference {meta['integrator']}, {meta['spp']} passes, {meta['width']}x{meta['height']}, "
              f"{meta['seconds']:.1f} s, seed {meta['seed']} -> {a.output} (+ {cv.sidecar_path(a.output)})",
              file=sys.stderr)
        return 0
    if a.reference is None:
        raise _api.InputError("converge needs --reference REF.exr (or --make-reference -o REF.exr to render one)")
    if a.output is not None or a.spp is not None:
        raise _api.InputError("-o and --spp apply with --make-reference; use --out DIR for the run's outputs")
    out = a.out or f"converge-{os.path.splitext(os.path.basename(a.scene))[0]}"
    if os.path.exists(out) and not os.path.isdir(out):
        raise _api.InputError(f"--out '{out}' exists and is not a directory")
    parent = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(parent):
        raise _api.InputError(f"--out '{out}': directory '{parent}' does not exist")

    def prog(rec):
        errs = ", ".join(f"{cv.LABELS.get(m, m)} {rec[m]:.4g}" for m in cv.LIVE_METRICS if m in rec)
        _say(a.quiet, f"{rec['integrator']}: {rec['elapsed_s']:.2f} s, {rec['passes']} passes"
                      + (f", {errs}" if errs else "") + (" (final)" if rec["final"] else ""))

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = cv.converge(a.scene, integrators=a.integrators, time=a.time or 60.0, reference=a.reference,
                          metrics=a.metrics, checkpoints=a.at if a.at is not None else a.checkpoints,
                          seed=a.seed or 0, out_dir=out, crop=a.crop, progress=prog, as_frame=False,
                          **scene_kw, **opts)
    for w in {str(w.message) for w in caught}:
        print(f"caustica: warning: {w}", file=sys.stderr)
    finals = [r for r in log if r["final"]]
    for r in finals:
        vals = ", ".join(f"{cv.LABELS.get(m, m)} {r[m]:.4g}" for m in log.header["metrics"])
        print(f"{r['integrator']}: {r['elapsed_s']:.1f} s, {r['passes']} passes, {vals}", file=sys.stderr)
    print(f"-> {out}/converge.jsonl, {', '.join(m + '.png/.svg' for m in log.header['metrics'])}, grid.png",
          file=sys.stderr)
    return 0
