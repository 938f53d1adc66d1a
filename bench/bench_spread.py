#!/usr/bin/env python3
"""Spread of equal-time relMSE over repeated runs, caustica against SmallVCM, on one SmallVCM scene.

bench_bidirectional.py compares one run of each renderer per budget. Where relMSE is dominated by a few
bright outliers (fireflies: `bdpt` and SmallVCM `bpt` on `smallvcm-sun`, whose single-run ratios ranged from 0.16
to 2.1 between runs), one run says little; this script repeats the comparison and reports every run, the mean
and the median.

- caustica: `render_job(scene, integrator, time=W, seed=k)` for k = 1 .. runs (independent seeds).
- SmallVCM has no seed option (its image is a function of the iteration count), so its runs use iteration
  counts spread around the budget's: N - 2 (runs - 1) / 2 .. N + 2 (runs - 1) / 2 in steps of 2 (even counts for
  its 2 OpenMP threads). These runs are not independent (a run of more iterations repeats the fewer's first
  iterations' samples), so their spread understates SmallVCM's run-to-run variation.
- W: the wall time of SmallVCM's run with the budget's N (the same rule as bench_bidirectional.py).
- relMSE against bench_bidirectional.py's cached caustica `vcm` reference (run that script first).

Usage: .venv/bin/python bench/bench_spread.py --scene 0 --integrator bdpt --budget 10 --runs 5
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bench_bidirectional as bb  # noqa: E402
import bench_smallvcm as bs  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=int, default=0, help="SmallVCM scene index 0..3")
    ap.add_argument("--integrator", default="bdpt", choices=sorted(bb.PEER))
    ap.add_argument("--budget", type=float, default=10.0, help="seconds")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--smallvcm", default="/tmp/smallvcm/smallvcm")
    a = ap.parse_args(argv)
    import caustica

    sv = bs.SmallVCM(a.smallvcm)
    alg = bb.PEER[a.integrator]
    ref = bb.caustica_reference(caustica, a.scene, 0.0)["image"]
    slope, fixed = sv.per_iteration(a.scene, alg, 2, 6)
    n = bs.even((a.budget - fixed) / slope)
    _, wall = sv.render(a.scene, alg, n)
    bs.log(f"scene {a.scene} ({bs.SCENES[a.scene]}): SmallVCM {alg} {slope:.3f} s/iteration, N = {n}, W = {wall:.2f} s")
    sc = caustica.load_scene(bs.SCENES[a.scene])
    caustica.render_job(sc, integrator=a.integrator, spp=1)  # warm-up
    rows = []
    half = (a.runs - 1) // 2
    for k in range(a.runs):
        ni = max(2, n + 2 * (k - half))
        with bb.Meter() as m1:
            img, w = sv.render(a.scene, alg, ni)
        e_sv = bs.rel_mse(img, ref)
        with bb.Meter() as m2:
            r = caustica.render_job(sc, integrator=a.integrator, time=wall, seed=k + 1)
        e_c = bs.rel_mse(r.image, ref)
        rows.append((ni, w, e_sv, k + 1, int(r.stats["passes"]), float(r.stats["seconds"]), e_c,
                     max(m1.other, m2.other)))
        bs.log(f"  run {k + 1}: SmallVCM {alg} -i {ni}: {w:.2f} s relMSE {e_sv:.5f} | caustica {a.integrator} seed "
               f"{k + 1}: {rows[-1][4]} passes {rows[-1][5]:.2f} s relMSE {e_c:.5f} | other cores "
               f"{rows[-1][7]:.2f}")
    sv_e = [r[2] for r in rows]
    c_e = [r[6] for r in rows]
    print(f"| scene | budget (s) | runs | SmallVCM {alg} relMSE per run | mean | median | caustica {a.integrator} "
          f"relMSE per run | mean | median | ratio of means | ratio of medians |")
    print("|---|---:|---:|---|---:|---:|---|---:|---:|---:|---:|")
    print(f"| {a.scene} {bs.SCENES[a.scene]} | {a.budget:g} | {a.runs} | "
          f"{', '.join(f'{e:.4f}' for e in sv_e)} | {statistics.mean(sv_e):.4f} | {statistics.median(sv_e):.4f} | "
          f"{', '.join(f'{e:.4f}' for e in c_e)} | {statistics.mean(c_e):.4f} | {statistics.median(c_e):.4f} | "
          f"**{statistics.mean(c_e) / statistics.mean(sv_e):.3f}** | "
          f"**{statistics.median(c_e) / statistics.median(sv_e):.3f}** |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
