"""Adaptive photon tracing (--photon-sampling adaptive, Hachisuka & Jensen 2011) against uniform photon tracing at
equal time, `sppm`, on two views of the Cornell box:

  closeup  the box seen through a 5-degree lens aimed at the ceiling beside the light (indirect light only;
           about 0.3% of uniform photon paths store a photon the camera's visible points gather);
  cornell  the built-in camera (about 40% of uniform paths visible);
  sunlit   tests/data/json/sunlit-room.json: a closed room lit by the sun through a small hole in its ceiling
           (about 0.2% of uniform paths visible);
  fog-closeup  (only with --views) tests/python/test_adaptive_photons.py's fog close-up: a point light in a box
           of fog over a floor, seen through a 6-degree lens aimed at the floor's far corner (about 0.1% of
           uniform paths visible, mostly through volume photons).

For each view and time budget, `--seeds` renders of each sampling; figures: passes done, relMSE against a
path-traced reference (closeup and cornell, diffuse views the path tracer renders well; not for the sunlit
room, whose indirect light from a small sunlit patch the path tracer finds too rarely for a reference), mean
per-pixel variance over the seeds (noise) over all pixels and over the dim 90% (below the 90th percentile of
uniform tracing's mean: the indirectly lit pixels), and their ratios adaptive / uniform (below 1: adaptive is
better at equal time).

    .venv/bin/python bench/bench_adaptive.py [--res 64] [--budgets 2 8] [--seeds 4] [--photons 100000]
        [--views closeup cornell sunlit fog-closeup]

Appends a block to bench/RESULTS.md."""
from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import sys
import tempfile

import numpy as np

import caustica

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "python"))
from caustica._provenance import commit as _provenance_commit, machine  # noqa: E402


def relmse(x, r):
    return float(np.mean((x - r) ** 2 / (r ** 2 + 0.01)))


def views(res: int, names: list) -> dict:
    sys.path.insert(0, os.path.join(ROOT, "tests", "python"))
    from test_adaptive_photons import fog_closeup
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "cornell.json")
        caustica.load_scene_desc("cornell").write_json(path)
        d = json.load(open(path))
    close = dict(d)
    close["camera"] = {"position": [0, 0, 0.8], "target": [0.6, 1, -0.6], "up": [0, 1, 0], "fov": 5.0,
                       "width": res, "height": res}
    room = os.path.join(ROOT, "tests", "data", "json", "sunlit-room.json")
    make = {"closeup": lambda: caustica.load_scene(close),
            "cornell": lambda: caustica.load_scene("cornell", width=res, height=res),
            "sunlit": lambda: caustica.load_scene(room, width=res, height=res),
            "fog-closeup": lambda: caustica.load_scene(fog_closeup(width=res))}
    return {n: make[n]() for n in names}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--budgets", type=float, nargs="+", default=[2.0, 8.0])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--photons", type=int, default=100000)
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--views", nargs="+", default=["closeup", "cornell", "sunlit"],
                    choices=["closeup", "cornell", "sunlit", "fog-closeup"])
    ap.add_argument("--no-append", action="store_true")
    a = ap.parse_args()
    rows = []
    for name, scene in views(a.res, a.views).items():
        ref = None if name == "sunlit" else caustica.render(scene, spp=a.ref_spp, seed=12345,
                                                            sampler="independent").astype(np.float64)
        for T in a.budgets:
            res = {}
            for sampling in ("uniform", "adaptive"):
                imgs, passes, extra = [], [], None
                for s in range(1, a.seeds + 1):
                    r = caustica.render_job(scene, integrator="sppm", time=T, seed=s, photons=a.photons,
                                            photon_sampling=sampling)
                    imgs.append(r.image.astype(np.float64))
                    passes.append(r.stats["passes"])
                    extra = r.stats.get("adaptive") or extra
                imgs = np.array(imgs)
                res[sampling] = dict(passes=float(np.mean(passes)), imgs=imgs, adaptive=extra,
                                     relmse=None if ref is None else float(np.mean([relmse(i, ref) for i in imgs])))
            u, ad = res["uniform"], res["adaptive"]
            lum = u["imgs"].mean(axis=(0, 3))
            dim = lum < np.percentile(lum, 90)
            for r in (u, ad):
                var = r.pop("imgs").var(axis=0, ddof=1).mean(axis=2)
                r["variance"], r["variance_dim"] = float(var.mean()), float(var[dim].mean())
            print(name, T, u, ad, flush=True)
            rows.append((name, T, u, ad))
    if a.no_append:
        return 0
    date = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    cmd = (f".venv/bin/python bench/bench_adaptive.py --res {a.res} --budgets {' '.join(f'{b:g}' for b in a.budgets)} "
           f"--seeds {a.seeds} --photons {a.photons} --ref-spp {a.ref_spp} --views {' '.join(a.views)}")
    lines = [f"\n## Adaptive photon tracing vs uniform, sppm at equal time, {date}, commit {_provenance_commit(ROOT)}\n",
             f"Command: `{cmd}`  ",
             f"Machine: {machine()}; load average {os.getloadavg()[0]:.2f} at the end  ",
             f"Views of `cornell` at {a.res}x{a.res} (closeup: 5-degree lens on the ceiling beside the light); "
             f"sunlit: tests/data/json/sunlit-room.json; fog-closeup: a 6-degree lens on fog over a floor "
             f"(tests/python/test_adaptive_photons.py); relMSE against {a.ref_spp}-spp path tracing (not for sunlit), "
             f"mean over {a.seeds} seeds; variance: per pixel over the seeds, mean over pixels and channels, all "
             "pixels and the dim 90% (indirectly lit). Ratios adaptive / uniform: below 1, adaptive is better.\n",
             "| view | budget s | passes uniform | passes adaptive | visible % | acceptance | relMSE uniform | "
             "relMSE adaptive | relMSE ratio | variance ratio | variance ratio, dim 90% |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, T, u, ad in rows:
        info = ad["adaptive"] or {}
        rel = (f"{u['relmse']:.4g} | {ad['relmse']:.4g} | {ad['relmse'] / u['relmse']:.3f}" if u["relmse"] is not None
               else "— | — | —")
        lines.append(f"| {name} | {T:g} | {u['passes']:.1f} | {ad['passes']:.1f} | "
                     f"{100 * info.get('visible_fraction', 0):.3g} | {info.get('acceptance', 0):.3f} | {rel} | "
                     f"{ad['variance'] / u['variance']:.3f} | {ad['variance_dim'] / u['variance_dim']:.3f} |")
    with open(os.path.join(HERE, "RESULTS.md"), "a") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
