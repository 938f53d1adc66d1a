#!/usr/bin/env python3
"""What the lane-parallel `path` driver gains: the same render with lanes=True and lanes=False, alternating, in
one process.

integrator/path_lanes.cpp traces eight paths in lockstep with AVX2 shading arithmetic and gives the same image
bit for bit as one path at a time (tests/cpp/test_path_lanes.cpp), so the only difference between the two
renders is time. This script renders each scene --repeats times each way (after one warm-up render each way),
alternating so that drifts of the machine's speed hit both alike, checks that the two images are identical
and that stats["lanes"] says which driver ran, and reports the median times and their ratio (scalar / lanes:
above 1, the lanes are faster). Printed and appended to bench/RESULTS.md (unless --no-append).

Usage:
    .venv/bin/python bench/bench_lanes.py                                   # about 4 minutes on 2 cores
    .venv/bin/python bench/bench_lanes.py --scenes cornell --threads 1 --spp 16 --repeats 7 --no-append
"""
from __future__ import annotations

import argparse
import datetime as _dt
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402

import caustica  # noqa: E402
from bench_cornell_depth import ROOT, append_block  # noqa: E402
from caustica._provenance import commit  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["cornell", "smallvcm-spheres"])
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--no-append", action="store_true")
    a = ap.parse_args()
    started = _dt.datetime.now(_dt.timezone.utc)
    com = commit(ROOT)
    rows = []
    for name in a.scenes:
        scene = caustica.load_scene(name)
        for threads in a.threads:
            def render(lanes):
                t = time.perf_counter()
                r = caustica.render_job(scene, spp=a.spp, seed=1, threads=threads, lanes=lanes)
                return time.perf_counter() - t, r

            images = {}
            for lanes in (True, False):  # warm-up, and the identity check
                _, r = render(lanes)
                images[lanes] = r.image
                if r.stats["lanes"] != (8 if lanes else 0):
                    print(f"{name}: stats['lanes'] = {r.stats['lanes']} with lanes={lanes}: the lanes do not "
                          "run for this scene or CPU", file=sys.stderr)
                    return 1
            if not np.array_equal(images[True], images[False]):
                print(f"{name}: the images with and without lanes differ", file=sys.stderr)
                return 1
            times = {True: [], False: []}
            for _ in range(a.repeats):
                for lanes in (True, False):
                    times[lanes].append(render(lanes)[0])
            med = {k: statistics.median(v) for k, v in times.items()}
            ratio = med[False] / med[True]
            spread = " ".join(f"{t:.2f}" for t in sorted(times[True])) + " / " + \
                " ".join(f"{t:.2f}" for t in sorted(times[False]))
            print(f"{name}, {threads} thread(s): lanes {med[True]:.3f} s, one path at a time {med[False]:.3f} s "
                  f"(medians of {a.repeats}): {ratio:.2f}x; all runs {spread}", flush=True)
            rows.append([name, str(threads), f"{med[True]:.3f}", f"{med[False]:.3f}", f"{ratio:.2f}", spread])
    if not a.no_append:
        append_block("bench_lanes.py", started, com, "lane-parallel path driver against one path at a time",
                     f"Settings: each scene at its own resolution and filter, {a.spp} spp, seed 1, alternating "
                     f"renders in one process after one warm-up each; images checked bit-identical; times in "
                     f"seconds, medians of {a.repeats}.",
                     ["scene", "threads", "lanes (s)", "one path at a time (s)", "speed-up", "all runs: lanes / one path at a time"],
                     rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
