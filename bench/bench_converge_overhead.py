#!/usr/bin/env python3
"""What a convergence run costs the render it measures.

For each integrator, the same time budget is rendered twice per repeat: plainly (caustica.render_job,
time=T, no checkpoints) and by caustica.converge (checkpoints 8 per decade from 0.5 s, the cheap
metrics on each snapshot while the render runs, the expensive ones after it ends). The figure is
the work done in the budget: overhead = 1 - passes(converge) / passes(plain). The two runs of a
repeat are interleaved and their order alternates between repeats; the median over repeats is
reported. The metric time after the render (FLIP, SSIM on the kept snapshots) is reported apart:
it adds to the wall time of a run, not to the render it measures.

    .venv/bin/python bench/bench_converge_overhead.py [--scene cornell] [--time 15] [--repeats 3]
        [--integrators path,sppm] [--metrics relmse,flip] [--no-write]

Appends a block to bench/RESULTS.md (machine, commit, command, figure), unless --no-write.
"""
from __future__ import annotations

import argparse
import datetime as dt
import os
import resource
import statistics
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


import caustica
from caustica.converge import make_reference

SECTION = "# Convergence runs: checkpoint overhead (`bench/bench_converge_overhead.py`)"


from caustica._provenance import commit as _provenance_commit, machine  # noqa: E402


def commit() -> str:
    return _provenance_commit(ROOT)


def busy_jiffies() -> int:
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:]]
    return sum(v) - v[3] - (v[4] if len(v) > 4 else 0)  # all but idle and iowait


def own_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


class OtherWork:
    """CPU (in cores) taken by other processes while the block runs, from /proc/stat."""

    def __enter__(self):
        self.j0, self.c0, self.t0 = busy_jiffies(), own_cpu(), time.monotonic()
        return self

    def __exit__(self, *exc):
        hz = os.sysconf("SC_CLK_TCK")
        wall = time.monotonic() - self.t0
        self.cores = max(0.0, ((busy_jiffies() - self.j0) / hz - (own_cpu() - self.c0)) / wall)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="cornell")
    ap.add_argument("--width", type=int, default=None)
    ap.add_argument("--height", type=int, default=None)
    ap.add_argument("--time", type=float, default=15.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--integrators", default="path,sppm")
    ap.add_argument("--metrics", default="relmse,flip")
    ap.add_argument("--no-write", action="store_true")
    a = ap.parse_args(argv)
    integrators = a.integrators.split(",")
    cmd = "python bench/bench_converge_overhead.py " + " ".join(argv if argv is not None else sys.argv[1:])
    date = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    mach, rev = machine(), commit()
    scene = caustica.load_scene(a.scene, width=a.width, height=a.height)
    with tempfile.TemporaryDirectory() as tmp:
        ref = os.path.join(tmp, "ref.exr")
        make_reference(scene, ref, time=5.0)  # its quality does not matter here, only its size
        caustica.render(scene, spp=4)  # warm-up: the acceleration structure, page faults
        rows = []
        with OtherWork() as other:
            for integ in integrators:
                plain, conv, post, ncp, cpu = [], [], [], [], []
                for rep in range(a.repeats):
                    order = ("plain", "converge") if rep % 2 == 0 else ("converge", "plain")
                    for mode in order:
                        if mode == "plain":
                            r = caustica.render_job(scene, integrator=integ, time=a.time)
                            plain.append(r.stats["passes"])
                        else:
                            t0 = time.monotonic()
                            log = caustica.converge(scene, integrators=[integ], time=a.time, reference=ref,
                                                    metrics=a.metrics, as_frame=False)
                            wall = time.monotonic() - t0
                            conv.append(log[-1]["passes"])
                            post.append(wall - log[-1]["wall_s"])
                            ncp.append(len(log))
                            cpu.append(log[-1]["measure_cpu_s"])
                        print(f"{integ} repeat {rep + 1} {mode}: {(plain if mode == 'plain' else conv)[-1]} passes",
                              file=sys.stderr, flush=True)
                ratios = [1 - c / p for p, c in zip(plain, conv)]
                rows.append(dict(integ=integ, plain=plain, conv=conv, overhead=statistics.median(ratios),
                                 spread=(min(ratios), max(ratios)), post=statistics.median(post),
                                 checkpoints=max(ncp), cpu=statistics.median(cpu)))
    w, h = scene.width, scene.height
    lines = [f"## {date}, commit {rev}", "",
             f"Command: `{cmd.strip()}`  ",
             f"Settings: scene `{a.scene}` {w}x{h}, {a.time:g} s per render, {a.repeats} repeats (plain and converge "
             f"interleaved, order alternating), converge metrics {a.metrics} (live: "
             f"{', '.join(m for m in a.metrics.split(',') if m in ('mse', 'rmse', 'relmse', 'mape')) or 'none'}; "
             f"the rest after the render), default checkpoints (8 per decade from 0.5 s).  ",
             f"Other work on the machine during the runs: {other.cores:.2f} of {os.cpu_count()} cores on average.  ",
             "",
             "| date | machine | commit | command | integrator | passes plain | passes converge | checkpoints "
             "| overhead (median; min..max) | measuring CPU during the render (s; bound) | metric time after the render (s) |",
             "|---|---|---|---|---|---|---|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {date} | {mach} | {rev} | `caustica converge {a.scene} --integrators {r['integ']} "
                     f"--time {a.time:g}` vs `caustica render {a.scene} --integrator {r['integ']} --time {a.time:g}` "
                     f"| {r['integ']} | {', '.join(map(str, r['plain']))} | {', '.join(map(str, r['conv']))} "
                     f"| {r['checkpoints']} | **{100 * r['overhead']:.1f}%** ({100 * r['spread'][0]:.1f}..{100 * r['spread'][1]:.1f}%) "
                     f"| {r['cpu']:.3f} ({100 * r['cpu'] / a.time:.2f}%) | {r['post']:.2f} |")
    block = "\n".join(lines) + "\n"
    print(block)
    if not a.no_write:
        path = os.path.join(ROOT, "bench", "RESULTS.md")
        with open(path) as f:
            text = f.read()
        with open(path, "a") as f:
            if SECTION not in text:
                f.write("\n\n" + SECTION + "\n\n"
                        "Overhead: 1 − passes(converge) / passes(plain render) at the same time budget, same "
                        "integrator and seed; negative values are noise (the plain render did less). Measuring CPU: "
                        "the polling thread's CPU seconds while the render ran (snapshot copies, live metrics; "
                        "median over repeats); the bound in brackets, CPU / budget, is the throughput loss if "
                        "every one of those seconds had stopped all render threads (copies do, under the film's "
                        "mutex), so it does not depend on other work on the machine. The metric "
                        "time after the render is the FLIP/SSIM work on the kept snapshots (it lengthens a run, "
                        "not the render it measures). See docs/convergence.md.\n")
            f.write("\n" + block)
    return 0


if __name__ == "__main__":
    sys.exit(main())
