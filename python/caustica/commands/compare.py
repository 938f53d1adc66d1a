"""`caustica compare A B`: metrics of image A against the reference B (docs/metrics.md)."""
from __future__ import annotations

import json
import math
import sys

import numpy as np

from .. import metrics as M
from .._api import InputError


def add_parser(sub):
    from ..cli import _float  # the CLI's number checks: one line naming the option
    p = sub.add_parser("compare", help="metrics of an image against a reference (relMSE, FLIP, SSIM, ...)",
                       description="Compares image A with the reference B (.exr, .pfm, .png, .npy, .npz) and "
                                   "prints one line per metric.")
    p.add_argument("image", metavar="A", help="the image to judge")
    p.add_argument("reference", metavar="B", help="the reference image")
    p.add_argument("--metrics", default=",".join(M.DEFAULT_METRICS),
                   help=f"comma-separated, from: {', '.join(M.METRICS)} (default: {','.join(M.DEFAULT_METRICS)})")
    p.add_argument("--error-map", default=None, metavar="OUT",
                   help="write a per-pixel error map: .png in false colour (magma), .exr/.pfm raw values")
    p.add_argument("--map-metric", default="flip",
                   help=f"the error map's metric: {', '.join(M.ERROR_MAPS)} (default: flip)")
    p.add_argument("--exposure", type=_float("--exposure"), default=0.0,
                   help="scale both images by 2^exposure before tonemapping (ssim, flip, flip-hdr)")
    p.add_argument("--json", action="store_true", help="print {metric: value} as JSON")
    return p


def run(a) -> int:
    names = tuple(n.strip() for n in a.metrics.split(",") if n.strip())
    names = M._check_metrics(names)
    if a.error_map is not None:
        if a.map_metric not in M.ERROR_MAPS:
            raise InputError(f"unknown error map '{a.map_metric}' (allowed: {', '.join(M.ERROR_MAPS)})")
        M._check_write(a.error_map)
    img, ref = M.read(a.image), M.read(a.reference)
    if img.shape != ref.shape:
        raise InputError(f"images differ in size: {img.shape[1]}x{img.shape[0]} vs {ref.shape[1]}x{ref.shape[0]}")
    for path, x in ((a.image, img), (a.reference, ref)):
        bad = int(np.count_nonzero(~np.isfinite(x)))
        if bad:
            print(f"caustica: warning: '{path}' has {bad} non-finite values", file=sys.stderr)
    values = M.evaluate(img, ref, names, exposure=a.exposure)
    if a.json:
        print(json.dumps({k: (v if math.isfinite(v) else None) for k, v in values.items()}, indent=2))
    else:
        for k, v in values.items():
            note = f"  (eps {M.EPS:g})" if k in ("relmse", "mape") else ""
            print(f"{k:9s}{v:.6g}{note}")
    if a.error_map is not None:
        emap = M.error_map(img, ref, a.map_metric, exposure=a.exposure)
        vmax = 1.0 if a.map_metric.startswith("flip") else None
        lo, hi = M.write_error_map(a.error_map, emap, vmax=vmax)
        how = "magma" if a.error_map.lower().endswith(".png") else "raw values"
        print(f"error map: {a.map_metric} per pixel, {how}, {lo:.4g} .. {hi:.4g} -> {a.error_map}", file=sys.stderr)
    return 0
