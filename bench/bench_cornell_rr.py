#!/usr/bin/env python3
"""Whether the path tracer's Russian roulette costs efficiency on `cornell`: relMSE, time and their product
(inverse efficiency: lower is better) at equal spp for several rr_depth values.

Russian roulette (path.h: continuation probability min(max(beta) * eta^2, 0.95) from rr_depth segments on, the
rule of Mitsuba 3 and pbrt-v4) trades variance for shorter paths. bench_cornell.py compares caustica with
Mitsuba at rr_depth 5 (Mitsuba's default); this script says whether another start depth would give a better
relMSE x time on the same scene, i.e. whether the rule is where the benchmark's ratio could be won.

Renders `cornell` (256x256, box filter, max depth 8, sobol) at --spp with seeds 1..--seeds for each rr_depth,
against a reference of --ref-spp (sobol, seed 77, rr_depth 8: no roulette), timed in this process (all
threads). Printed and appended to bench/RESULTS.md (unless --no-append).

Usage:
    .venv/bin/python bench/bench_cornell_rr.py                      # about 5 minutes on 2 cores
    .venv/bin/python bench/bench_cornell_rr.py --rr 3 5 8 --seeds 2 --no-append
"""
from __future__ import annotations

import argparse
import datetime as _dt
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import caustica  # noqa: E402
from bench_cornell import rel_mse  # noqa: E402
from bench_cornell_depth import ROOT, append_block, mean_se  # noqa: E402
from caustica._provenance import commit  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rr", type=int, nargs="+", default=[2, 3, 4, 5, 6, 8])
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--ref-spp", type=int, default=2048)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--no-append", action="store_true")
    a = ap.parse_args()
    started = _dt.datetime.now(_dt.timezone.utc)
    com = commit(ROOT)
    scene = caustica.load_scene("cornell", filter="box")

    def render(spp, seed, rr):
        return caustica.render(scene, integrator="path", spp=spp, seed=seed, max_depth=8, rr_depth=rr,
                               sampler="sobol").astype("float64")

    t = time.perf_counter()
    ref = render(a.ref_spp, 77, 8)
    print(f"reference: {a.ref_spp} spp in {time.perf_counter() - t:.1f} s, mean {ref.mean():.5f}", flush=True)
    render(4, 99, 5)  # warm-up (first-render costs out of the timings)
    rows = []
    for rr in a.rr:
        errs, secs = [], []
        for seed in range(1, a.seeds + 1):
            t = time.perf_counter()
            img = render(a.spp, seed, rr)
            secs.append(time.perf_counter() - t)
            errs.append(rel_mse(img, ref))
        (e, se), s = mean_se(errs), sum(secs) / len(secs)
        rows.append((rr, e, se, s, e * s))
        print(f"rr_depth {rr}: relMSE {e:.6f} ± {se:.6f}, {s:.3f} s, relMSE x time {e * s:.6f}", flush=True)
    base = next((r for r in rows if r[0] == 5), rows[0])
    if a.no_append:
        return 0
    append_block("bench_cornell_rr.py", started, com, "cornell, Russian roulette start depth against efficiency",
                 f"Settings: cornell 256x256, box filter, max depth 8, sobol, {a.spp} spp, seeds 1-{a.seeds} (mean ± "
                 f"standard error over seeds), all threads, timed in one process; reference sobol {a.ref_spp} spp "
                 f"(seed 77) without roulette. Efficiency column: relMSE x time relative to rr_depth {base[0]} "
                 f"(below 1: more efficient).",
                 ["rr_depth", "relMSE", "time (s)", "relMSE x time", f"relative to rr_depth {base[0]}"],
                 [[str(rr), f"{e:.6f} ± {se:.6f}", f"{s:.3f}", f"{p:.6f}", f"{p / base[4]:.2f}"]
                  for rr, e, se, s, p in rows])
    return 0


if __name__ == "__main__":
    sys.exit(main())
