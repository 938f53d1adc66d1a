#!/usr/bin/env python3
"""Heterogeneous media against Mitsuba 3: the `smoky` scene of compare_mitsuba_xml.py (a gridvolume smoke
plume in a turned null box over a floor, volpath), rendered by caustica's `path` and Mitsuba's volpath at the
same resolution and spp on this machine's cores.

Per renderer and spp: the median seconds of the timed renders (after one warm-up render at that spp, which
for Mitsuba's LLVM variant includes its JIT compilation), and relMSE against a reference (the mean of
caustica's and Mitsuba's 1024-spp renders: the two agree, ratio 0.99 in compare_mitsuba_xml.py), averaged over
the seeds. The figure of merit is relMSE x seconds (lower is better); the ratio caustica / Mitsuba below 1
means caustica reaches a given error sooner.

usage: DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so .venv/bin/python bench/bench_media_grid.py
       [--res 128] [--spp 16 64] [--seeds 3] [--no-results]
(needs Mitsuba 3 from PyPI: bench/install-mitsuba.sh)
"""
import argparse
import datetime
import os
import statistics
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import compare_mitsuba_xml as cmx  # noqa: E402
from bench_cornell_depth import append_block  # noqa: E402

import caustica  # noqa: E402
from caustica import _provenance  # noqa: E402


def relmse(a, ref):
    return float(np.mean((a - ref) ** 2 / (ref ** 2 + 0.01)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--spp", type=int, nargs="+", default=[16, 64])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--no-results", action="store_true")
    args = ap.parse_args()
    started = datetime.datetime.now(datetime.timezone.utc)
    com = _provenance.commit(cmx.ROOT)
    import mitsuba as mi
    variant = "llvm_ad_rgb" if "llvm_ad_rgb" in mi.variants() else "scalar_rgb"
    mi.set_variant(variant)
    path = cmx.write_scenes(args.res)["smoky"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene_c = caustica.load_scene(path, width=args.res, height=args.res)
    scene_m = mi.load_file(path)

    def render_c(spp, seed):
        t = time.perf_counter()
        img = caustica.render(scene_c, spp=spp, seed=seed)
        return np.asarray(img, np.float64), time.perf_counter() - t

    def render_m(spp, seed):
        t = time.perf_counter()
        img = np.asarray(mi.render(scene_m, spp=spp, seed=seed), np.float64)[:, :, :3]
        return img, time.perf_counter() - t

    ref = 0.5 * (render_c(args.ref_spp, 1000)[0] + render_m(args.ref_spp, 1000)[0])
    rows = []
    for spp in args.spp:
        out = {}
        for name, fn in (("caustica", render_c), ("mitsuba", render_m)):
            fn(spp, 999)  # warm-up
            times, errs = [], []
            for s in range(args.seeds):
                img, t = fn(spp, s)
                times.append(t)
                errs.append(relmse(img, ref))
            out[name] = (statistics.median(times), float(np.mean(errs)))
        (tc, ec), (tm, em) = out["caustica"], out["mitsuba"]
        ratio = (ec * tc) / (em * tm)
        print(f"smoky {args.res}x{args.res} {spp} spp: caustica {tc:.3f} s relMSE {ec:.5f}; Mitsuba {mi.__version__} "
              f"({variant}) {tm:.3f} s relMSE {em:.5f}; time ratio {tc / tm:.2f}, relMSE x time ratio {ratio:.2f}")
        rows.append((spp, tc, ec, tm, em, ratio))
    if args.no_results:
        return
    append_block("bench_media_grid.py", started, com, "heterogeneous media against Mitsuba 3",
                 f"Scene `smoky` (compare_mitsuba_xml.py: a 24^3 gridvolume plume, volpath max_depth 16) at "
                 f"{args.res}x{args.res}, both renderers on all cores; Mitsuba {mi.__version__} ({variant}); "
                 f"reference: the mean of both at {args.ref_spp} spp; medians of {args.seeds} timed renders after "
                 f"a warm-up; relMSE averaged over the seeds.",
                 ["spp", "caustica s", "caustica relMSE", "Mitsuba s", "Mitsuba relMSE",
                  "relMSE x time, caustica / Mitsuba"],
                 [[str(spp), f"{tc:.3f}", f"{ec:.5f}", f"{tm:.3f}", f"{em:.5f}", f"{ratio:.2f}"]
                  for spp, tc, ec, tm, em, ratio in rows])

if __name__ == "__main__":
    main()
