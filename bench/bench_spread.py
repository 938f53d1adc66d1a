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

With --variance P it measures instead the variance part of relMSE without the reference's bias and with the
outliers of P passes sampled: caustica renders two seeds of P passes each, A and B, and
V = mean((A - B)^2 / (r^2 + 0.01)) / 2 is the relMSE variance of one P-pass image; SmallVCM renders -i P and
-i 2P, whose second half B = 2 img(2P) - img(P) is independent of img(P), and V likewise. Variance falls as
1/passes, so at equal time the ratio is V_caustica / V_SmallVCM x (SmallVCM's iterations per second /
caustica's passes per second).

Usage: .venv/bin/python bench/bench_spread.py --scene 0 --integrator bdpt --budget 10 --runs 5
       .venv/bin/python bench/bench_spread.py --scene 0 --integrator bdpt --variance 100
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
    ap.add_argument("--variance", type=int, default=0, metavar="P",
                    help="measure the per-pass variance from independent halves of P passes instead")
    a = ap.parse_args(argv)
    import caustica
    if a.variance > 0:
        return variance(a, caustica)

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


def variance(a, caustica) -> int:
    import numpy as np
    sv = bs.SmallVCM(a.smallvcm)
    alg = bb.PEER[a.integrator]
    ref = bb.caustica_reference(caustica, a.scene, 0.0)["image"].astype(np.float64)
    P = a.variance
    w_rel = 1.0 / (ref ** 2 + 0.01)
    with bb.Meter() as m1:
        img1, w1 = sv.render(a.scene, alg, P)
        img2, w2 = sv.render(a.scene, alg, 2 * P)
    second = 2.0 * img2.astype(np.float64) - img1
    v_sv = float((((img1 - second) ** 2) * w_rel).mean()) / 2.0
    rate_sv = P / max(w2 - w1, 1e-9)  # iterations per second, without the fixed start-up cost
    sc = caustica.load_scene(bs.SCENES[a.scene])
    caustica.render_job(sc, integrator=a.integrator, spp=1)  # warm-up
    imgs, secs = [], []
    with bb.Meter() as m2:
        for seed in (1, 2):
            r = caustica.render_job(sc, integrator=a.integrator, spp=P, seed=seed)
            imgs.append(np.asarray(r.image, dtype=np.float64))
            secs.append(float(r.stats["seconds"]))
    v_c = float((((imgs[0] - imgs[1]) ** 2) * w_rel).mean()) / 2.0
    rate_c = 2 * P / sum(secs)
    ratio = v_c / v_sv * rate_sv / rate_c
    bs.log(f"scene {a.scene}: SmallVCM {alg} -i {P}: {w1:.2f} s, -i {2 * P}: {w2:.2f} s ({rate_sv:.3f} it/s); caustica "
           f"{a.integrator} 2 x {P} passes: {secs[0]:.2f} + {secs[1]:.2f} s ({rate_c:.3f} passes/s); other cores "
           f"{max(m1.other, m2.other):.2f}")
    print(f"| scene | P | SmallVCM {alg} variance relMSE (P) | it/s | caustica {a.integrator} variance relMSE (P) | "
          f"passes/s | per-pass ratio | equal-time ratio |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    print(f"| {a.scene} {bs.SCENES[a.scene]} | {P} | {v_sv:.5f} | {rate_sv:.3f} | {v_c:.5f} | {rate_c:.3f} | "
          f"{v_c / v_sv:.3f} | **{ratio:.3f}** |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
