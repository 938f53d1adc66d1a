#!/usr/bin/env python3
"""What the wavefront drivers cost on the CPU: ms per pass of each integrator's CPU driver and of the same
integrator's wavefront driver on the CPU backend (`wavefront=True`: the code the CUDA backend runs), in one
process, alternating the two renders --rounds times so that drift in the machine's speed hits both alike.

The wavefront keeps every path's state in memory between stages and adds queue bookkeeping (compaction,
prefix sums, sorting light vertices and splats into path order); the ratio wavefront / CPU driver is its
price on a CPU, where the stages' arithmetic is the same code. Images are equal (bit for bit for path,
light, bdpt, bpm, vcm and upg; tests/cpp/test_wavefront.cpp), so only time is compared.

Usage:
    .venv/bin/python bench/bench_wavefront_cpu.py                      # about 3 minutes on 2 cores
    .venv/bin/python bench/bench_wavefront_cpu.py --integrators bdpt vcm --size 128 --no-append
"""
from __future__ import annotations

import argparse
import datetime as _dt
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import caustica  # noqa: E402
from bench_cornell_depth import ROOT, append_block, mean_se  # noqa: E402
from caustica._provenance import commit  # noqa: E402


def ms_per_pass(scene, integrator: str, passes: int, wavefront: bool) -> float:
    st = caustica.render_job(scene, integrator=integrator, spp=passes, seed=1, max_depth=8,
                             wavefront=wavefront).stats
    return 1e3 * st["seconds"] / st["passes"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="smallvcm-spheres")
    ap.add_argument("--size", type=int, default=256, help="width and height")
    ap.add_argument("--integrators", nargs="+", default=["path", "sppm", "light", "bdpt", "vcm", "upg"])
    ap.add_argument("--passes", type=int, default=4)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--no-append", action="store_true")
    a = ap.parse_args()
    started = _dt.datetime.now(_dt.timezone.utc)
    com = commit(ROOT)
    scene = caustica.load_scene(a.scene, width=a.size, height=a.size)
    rows = []
    for integ in a.integrators:
        ms_per_pass(scene, integ, 1, False)  # warm-up (the scene's accelerator, caches)
        ms_per_pass(scene, integ, 1, True)
        cpu, wf, ratio = [], [], []
        for _ in range(a.rounds):
            c = ms_per_pass(scene, integ, a.passes, False)
            w = ms_per_pass(scene, integ, a.passes, True)
            cpu.append(c)
            wf.append(w)
            ratio.append(w / c)
        (mc, sc), (mw, sw), (mr, sr) = mean_se(cpu), mean_se(wf), mean_se(ratio)
        print(f"{integ:6s} CPU driver {mc:8.1f} ± {sc:.1f} ms/pass   wavefront {mw:8.1f} ± {sw:.1f} ms/pass   "
              f"ratio {mr:.3f} ± {sr:.3f}")
        rows.append([integ, f"{mc:.1f} ± {sc:.1f}", f"{mw:.1f} ± {sw:.1f}", f"{mr:.3f} ± {sr:.3f}"])
    if not a.no_append:
        append_block("bench_wavefront_cpu.py", started, com, "the wavefront drivers on the CPU against the CPU drivers",
                     f"Scene {a.scene} {a.size}x{a.size}, max depth 8, {a.passes} passes per render, {a.rounds} "
                     f"alternating rounds (mean ± standard error), all threads.\n",
                     ["integrator", "CPU driver ms/pass", "wavefront ms/pass", "wavefront / CPU driver"], rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
