"""`caustica study realtime SCENE`: spp, frame time and missing speed-up for real-time quality.

    caustica study realtime cornell --integrators path sppm --thresholds 0.2 0.1 0.05 \\
        --max-spp 256 --seeds 3 --out out/realtime-cornell

Writes report.md (table and method), flip_vs_spp.{png,svg}, flip_vs_frame_time.{png,svg},
results.json and the cached reference into --out, and prints the table. Bad input: one line, exit 2.
"""
from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
import warnings

from .. import _api
from .. import study as S


from ..cli import _number as _type  # noqa: E402  (one argparse type factory for every command)


def _size(s):
    w, x, h = s.lower().partition("x")
    try:
        w, h = int(w), int(h)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size expects WIDTHxHEIGHT, e.g. 180x180, got '{s}'") from None
    if not x or w <= 0 or h <= 0:
        raise argparse.ArgumentTypeError(f"--size expects WIDTHxHEIGHT with positive numbers, got '{s}'")
    return w, h


def _param(s):
    name, eq, value = s.partition("=")
    if not eq or not name:
        raise argparse.ArgumentTypeError(f"--param expects NAME=VALUE, got '{s}'")
    return name, value


_pos = lambda name: _type(name, int, lambda v: v > 0, "a positive integer")


def add_parser(sub):
    p = sub.add_parser("study", help="studies of what users see (realtime: spp and frame time for a FLIP target)",
                       description="Studies of image quality against cost.")
    ss = p.add_subparsers(dest="study", parser_class=type(p), metavar="STUDY")
    ss.required = True
    r = ss.add_parser("realtime", help="spp needed per FLIP threshold, frame time at 1920x1080, speed-up missing "
                                       "for 16.7 ms",
                      description="For each integrator: the samples per pixel needed to bring mean FLIP below each "
                                  "threshold (measured at a small size), the throughput on this machine, the frame "
                                  "time at 1920x1080 and the speed-up still missing for 16.7 ms. Writes a Markdown "
                                  "report with plots into --out.")
    r.add_argument("scene", help="a built-in scene name or a scene file")
    r.add_argument("--integrators", nargs="+", default=None, metavar="NAME",
                   help=f"integrators to study (default: all: {', '.join(_api.integrators())}); also the variants "
                        f"{', '.join(_api.variant_names())}")
    r.add_argument("--thresholds", nargs="+", default=list(S.THRESHOLDS), metavar="FLIP",
                   type=_type("--thresholds", float, lambda v: 0 < v < 1 and math.isfinite(v), "numbers in (0, 1)"),
                   help=f"mean FLIP thresholds (default: {' '.join(map(str, S.THRESHOLDS))})")
    r.add_argument("--out", default=None, help="output folder (default: out/realtime-<scene>)")
    r.add_argument("--size", type=_size, default=None, metavar="WxH",
                   help="the small size rendered (default: the scene's aspect at 1/64 of 1920x1080's pixels)")
    r.add_argument("--max-spp", type=_pos("--max-spp"), default=S.DEFAULT_MAX_SPP,
                   help=f"largest spp (passes) measured: 1, 2, 4, ... up to it (default {S.DEFAULT_MAX_SPP})")
    r.add_argument("--seeds", type=_pos("--seeds"), default=S.DEFAULT_SEEDS,
                   help=f"renders per spp, FLIP averaged (default {S.DEFAULT_SEEDS})")
    r.add_argument("--ref-spp", type=_pos("--ref-spp"), default=S.DEFAULT_REF_SPP,
                   help=f"the reference's spp (default {S.DEFAULT_REF_SPP})")
    r.add_argument("--ref-integrator", default="path", help="the reference's integrator (default path)")
    r.add_argument("--fresh-ref", action="store_true", help="re-render the cached reference")
    r.add_argument("--flip", dest="flip_mode", default="ldr", choices=("ldr", "hdr"),
                   help="LDR-FLIP of the display images (default) or HDR-FLIP")
    r.add_argument("--max-depth", type=_type("--max-depth", int, lambda v: v == -1 or v > 0,
                                             "a positive integer or -1"), default=None)
    r.add_argument("--sampler", default=None, help="sobol or independent (default: the scene's)")
    r.add_argument("--threads", type=_type("--threads", int, lambda v: v >= 0, "a non-negative integer"), default=0)
    r.add_argument("--camera", default=None, help="a named camera of the scene file")
    r.add_argument("--variant", default=None, metavar="NAME", help="a material variant of a glTF file")
    r.add_argument("--param", type=_param, action="append", default=[], metavar="NAME=VALUE",
                   help="Mitsuba XML $NAME substitution (repeatable)")
    r.add_argument("--device", default="cpu",
                   help="cpu (default), cuda or cuda:N: render on the GPU (default integrators there: "
                        f"{', '.join(_api.CUDA_INTEGRATORS)})")
    r.add_argument("--throughput-at", choices=S.THROUGHPUT_AT, default=None,
                   help="small: the small renders' throughput scaled to 1080p by pixel count (the CPU's default); "
                        "1080p: measured at 1920x1080's pixel count (the GPU's default)")
    r.add_argument("--throughput-spp", type=_pos("--throughput-spp"), default=S.DEFAULT_THROUGHPUT_SPP,
                   help=f"passes per 1080p throughput render (default {S.DEFAULT_THROUGHPUT_SPP})")
    r.add_argument("--quiet", action="store_true", help="no progress lines")
    return p


def run(a) -> int:
    if a.sampler is not None and a.sampler not in _api.SAMPLERS:
        raise _api.InputError(f"unknown sampler '{a.sampler}' (allowed: {', '.join(_api.SAMPLERS)})")
    out = a.out or os.path.join("out", f"realtime-{os.path.splitext(os.path.basename(a.scene))[0]}")
    if os.path.exists(out) and not os.path.isdir(out):
        raise _api.InputError(f"cannot write to '{out}': it is not a directory")
    log = None if a.quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    command = "caustica " + " ".join(shlex.quote(x) for x in sys.argv[1:]) if sys.argv[1:2] == ["study"] else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", _api.SceneWarning)
        res = S.realtime(a.scene, integrators=a.integrators, thresholds=a.thresholds, size=a.size,
                         max_spp=a.max_spp, seeds=a.seeds, ref_spp=a.ref_spp, ref_integrator=a.ref_integrator,
                         out=out, flip_mode=a.flip_mode, threads=a.threads, max_depth=a.max_depth,
                         sampler=a.sampler, camera=a.camera, params=dict(a.param) or None, variant=a.variant,
                         fresh_ref=a.fresh_ref, device=a.device, throughput_at=a.throughput_at,
                         throughput_spp=a.throughput_spp,
                         log=log, command=command)
    seen = set()
    for w in caught:
        if str(w.message) not in seen:
            seen.add(str(w.message))
            print(f"caustica: warning: {w.message}", file=sys.stderr)
    print(S.format_table(res["table"]))
    print(f"\n{res['device_note']}\nreport: {res['report']}")
    return 0
