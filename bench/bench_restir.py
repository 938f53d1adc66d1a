"""ReSTIR DI (integrator restir, Bitterli et al. 2020) against the path tracer, direct light only (max_depth 2),
on two scenes:

  many-lights  tests/data/json/many-lights.json: 20 small emissive disks (2560 emitting triangles), a two-sided
               rectangle, two sphere lights, a point and a spot light and an environment map over a floor with
               occluders;
  cornell      the built-in Cornell box (one rectangular light);
  hazy-many-lights  many-lights inside a null box of haze (sigma_s 0.12, sigma_a 0.02, g 0.3; tests/python/
               test_media_restir.py): shading points in the haze too (--scenes hazy-many-lights).

Two questions. Offline: relMSE of the accumulated image against an --ref-spp path-traced reference at equal time
(mean over --seeds seeds), and the median per-pixel squared relative error (the relMSE's mean is decided by a
few pixels: the anti-aliased edges of emitters seen directly, where the path tracer's Sobol points converge
faster than 1/N and ReSTIR, which takes several times fewer passes in the time, is no help), for the path tracer and restir without reuse, with spatial reuse only, temporal only,
and both. Real time: one pass alone (pass 16, from the difference of two deterministic renders of 16 and 15
passes), its median per-pixel squared relative error (the mean is decided by a few heavy-tailed pixels), and
the milliseconds per pass.

    .venv/bin/python bench/bench_restir.py [--res 128] [--budgets 2 8] [--seeds 3] [--radius 10]
        [--scenes many-lights cornell hazy-many-lights]

Appends a block to bench/RESULTS.md."""
from __future__ import annotations

import argparse
import datetime as dt
import os
import sys

import numpy as np

import caustica

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "python"))
from caustica._provenance import commit as _provenance_commit, machine  # noqa: E402


def relmse(x, r):
    return float(np.mean((x - r) ** 2 / (r ** 2 + 0.01)))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--budgets", type=float, nargs="+", default=[2.0, 8.0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--radius", type=float, default=10.0)
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--scenes", nargs="+", default=["many-lights", "cornell"],
                    choices=["many-lights", "cornell", "hazy-many-lights"])
    ap.add_argument("--no-append", action="store_true")
    a = ap.parse_args()
    configs = {
        "path": ("path", {}),
        "restir, no reuse": ("restir", dict(restir_neighbors=0, restir_history=0)),
        "restir, spatial": ("restir", dict(restir_history=0, restir_radius=a.radius)),
        "restir, temporal": ("restir", dict(restir_neighbors=0)),
        "restir, both": ("restir", dict(restir_radius=a.radius)),
    }
    ml = os.path.join(ROOT, "tests", "data", "json", "many-lights.json")

    def hazy():
        sys.path.insert(0, os.path.join(ROOT, "tests", "python"))
        from test_media_restir import hazy_many_lights
        d = hazy_many_lights()
        d["camera"].update(width=a.res, height=a.res * 3 // 4)
        return d

    make = {"many-lights": lambda: caustica.load_scene(ml, width=a.res, height=a.res * 3 // 4),
            "cornell": lambda: caustica.load_scene("cornell", width=a.res, height=a.res),
            "hazy-many-lights": hazy}
    scenes = {n: make[n]() for n in a.scenes}
    rows = []
    for name, scene in scenes.items():
        ref = caustica.render(scene, spp=a.ref_spp, seed=12345, max_depth=2).astype(np.float64)
        for label, (integ, kw) in configs.items():
            row = {"scene": name, "config": label}
            for T in a.budgets:
                errs, meds, passes = [], [], []
                for s in range(a.seeds):
                    r = caustica.render_job(scene, integrator=integ, time=T, seed=s, max_depth=2, **kw)
                    x = r.image.astype(np.float64)
                    errs.append(relmse(x, ref))
                    meds.append(float(np.median((x - ref) ** 2 / (ref ** 2 + 0.01))))
                    passes.append(r.stats["passes"])
                row[T] = (float(np.mean(errs)), float(np.mean(meds)), float(np.mean(passes)))
            med, ms = [], []
            for s in range(a.seeds):
                r16 = caustica.render_job(scene, integrator=integ, spp=16, seed=s, max_depth=2, **kw)
                r15 = caustica.render_job(scene, integrator=integ, spp=15, seed=s, max_depth=2, **kw)
                x = 16 * r16.image.astype(np.float64) - 15 * r15.image.astype(np.float64)
                med.append(float(np.median((x - ref) ** 2 / (ref ** 2 + 0.01))))
                ms.append(1000 * r16.stats["seconds"] / 16)
            row["median"], row["ms"] = float(np.mean(med)), float(np.mean(ms))
            print(row, flush=True)
            rows.append(row)
    if a.no_append:
        return 0
    date = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    cmd = (f".venv/bin/python bench/bench_restir.py --res {a.res} --budgets {' '.join(f'{b:g}' for b in a.budgets)} "
           f"--seeds {a.seeds} --radius {a.radius:g} --ref-spp {a.ref_spp} --scenes {' '.join(a.scenes)}")
    head = " | ".join(f"relMSE {T:g} s | median {T:g} s (passes)" for T in a.budgets)
    lines = [f"\n## ReSTIR DI vs path tracing, direct light, {date}, commit {_provenance_commit(ROOT)}\n",
             f"Command: `{cmd}`  ",
             f"Machine: {machine()}; load average {os.getloadavg()[0]:.2f} at the end  ",
             f"max_depth 2 (direct light); many-lights (and hazy-many-lights) at {a.res}x{a.res * 3 // 4}, cornell at "
             f"{a.res}x{a.res}; "
             f"relMSE of the accumulated image against {a.ref_spp}-spp path tracing at equal time, mean over "
             f"{a.seeds} seeds, and the median per-pixel squared relative error; single pass: pass 16 alone, median per-pixel squared relative error; ms per pass "
             f"(CPU). restir defaults (32 candidates, 5 neighbours, history 20) with radius {a.radius:g} px.\n",
             f"| scene | integrator | {head} | single pass, median sq. rel. error | ms per pass |",
             "|---|---|" + "---|---|" * len(a.budgets) + "---|---|"]
    for r in rows:
        cells = " | ".join(f"{r[T][0]:.4g} | {r[T][1]:.3g} ({r[T][2]:.0f})" for T in a.budgets)
        lines.append(f"| {r['scene']} | {r['config']} | {cells} | {r['median']:.4g} | {r['ms']:.1f} |")
    with open(os.path.join(HERE, "RESULTS.md"), "a") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
