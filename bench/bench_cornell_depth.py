#!/usr/bin/env python3
"""Where the path tracer's error on `cornell` is: relMSE at equal spp by path depth, and how much of it the
light sample at secondary vertices accounts for.

For each max depth D in --depths (segments, Mitsuba's count: 2 = direct light only), renders `cornell`
(256x256, box filter, rr_depth 5 as bench_cornell.py) at --spp with seeds 1..--seeds for both samplers, and
a reference at --ref-spp (sobol, seed 77) of the same D. relMSE uses the denominators of the full-depth
(D = 8) reference, so the figures of different D add up: the difference between two rows is the error that
the extra depths bring. Printed and appended to bench/RESULTS.md (unless --no-append).

Usage:
    .venv/bin/python bench/bench_cornell_depth.py                 # about 6 minutes on 2 cores
    .venv/bin/python bench/bench_cornell_depth.py --depths 2 3 8 --seeds 2 --no-append
"""
from __future__ import annotations

import argparse
import datetime as _dt
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
RESULTS = os.path.join(HERE, "RESULTS.md")

import caustica  # noqa: E402
from caustica._provenance import commit, machine  # noqa: E402


def mean_se(values) -> tuple[float, float]:
    """Mean and its standard error (0 for a single value)."""
    v = np.asarray(values, dtype=np.float64)
    return float(v.mean()), (float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else 0.0)


def append_block(script: str, started: _dt.datetime, com: str, title: str, settings: str, columns: list[str],
                 rows: list[list[str]]) -> None:
    """Appends a RESULTS.md block: heading, the command as run, settings, and a table whose rows start with
    date, machine and commit (bench/bench_cornell_rr.py writes its block with this too). `com`: the commit
    read when the run started."""
    stamp = started.strftime("%Y-%m-%d %H:%M UTC")
    cmd = f"`.venv/bin/python bench/{script}" + "".join(" " + x for x in sys.argv[1:]) + "`"
    lines = [f"\n## {stamp}, commit {com}: {title}\n", f"Command: {cmd}  ", f"Machine: {machine()}. {settings}\n",
             "| " + " | ".join(["date", "machine", "commit"] + columns) + " |",
             "|---|---|---|" + "---:|" * len(columns)]
    lines += ["| " + " | ".join([stamp, machine(), com] + r) + " |" for r in rows]
    with open(RESULTS, "a") as f:
        f.write("\n".join(lines) + "\n")
    print("appended to bench/RESULTS.md")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--depths", type=int, nargs="+", default=[2, 3, 4, 8])
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--no-append", action="store_true")
    a = ap.parse_args()
    started = _dt.datetime.now(_dt.timezone.utc)
    com = commit(ROOT)
    scene = caustica.load_scene("cornell", filter="box")

    def render(spp, seed, depth, sampler):
        return caustica.render(scene, integrator="path", spp=spp, seed=seed, max_depth=depth, rr_depth=5,
                               sampler=sampler).astype(np.float64)

    refs = {}
    for d in sorted(set(a.depths) | {8}):
        t = time.perf_counter()
        refs[d] = render(a.ref_spp, 77, d, "sobol")
        print(f"reference depth {d}: {a.ref_spp} spp in {time.perf_counter() - t:.1f} s, mean {refs[d].mean():.5f}",
              flush=True)
    den = refs[8] ** 2 + 0.01
    rows = []
    for d in a.depths:
        row = {"depth": d}
        for smp in ("sobol", "independent"):
            row[smp] = mean_se([np.mean((render(a.spp, s, d, smp) - refs[d]) ** 2 / den)
                                for s in range(1, a.seeds + 1)])
        rows.append(row)
        print(f"max depth {d}: relMSE sobol {row['sobol'][0]:.6f} ± {row['sobol'][1]:.6f}, "
              f"independent {row['independent'][0]:.6f} ± {row['independent'][1]:.6f}", flush=True)
    if a.no_append:
        return 0
    append_block("bench_cornell_depth.py", started, com, "cornell relMSE by path depth",
                 f"Settings: cornell 256x256, box filter, rr_depth 5, {a.spp} spp, seeds 1-{a.seeds} "
                 f"(mean ± standard error over seeds); references sobol {a.ref_spp} spp (seed 77) per max depth; "
                 f"denominators r^2 + 0.01 from the max-depth-8 reference, so rows add up. The references' own error "
                 f"is included (at most about spp / ref spp = {a.spp / a.ref_spp:.3g} of a row's figure).",
                 ["max depth (segments)", "relMSE sobol", "relMSE independent", "sobol / independent"],
                 [[str(r["depth"]), f"{r['sobol'][0]:.6f} ± {r['sobol'][1]:.6f}",
                   f"{r['independent'][0]:.6f} ± {r['independent'][1]:.6f}",
                   f"{r['sobol'][0] / r['independent'][0]:.2f}"] for r in rows])
    return 0


if __name__ == "__main__":
    sys.exit(main())
