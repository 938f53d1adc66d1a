#!/usr/bin/env python3
"""What the light BVH gains: path tracing (or restir, sppm, bdpt, vcm) with light_sampler="power" against "bvh" at
equal samples and by time to equal error.

For each scene: a reference (power sampler, --ref-spp, its own seed), then per sampler --seeds renders of --spp
samples (after a warm-up render), alternating the samplers; relMSE against the reference averaged over the seeds,
render seconds the median. Time to equal relMSE, bvh / power = (relMSE_bvh x t_bvh) / (relMSE_power x t_power)
(relMSE falls as 1/samples): below 1, the BVH reaches the power sampler's error sooner. Both samplers run the
lane-parallel driver where the scene allows (stats["lanes"]; path only). The reference is path traced whatever
--integrator is. Printed and appended to bench/RESULTS.md unless --no-append.

Usage:
    .venv/bin/python bench/bench_light_sampler.py                 # about 3 minutes on 2 cores
    .venv/bin/python bench/bench_light_sampler.py --scenes cornell --spp 32 --no-append
    .venv/bin/python bench/bench_light_sampler.py --integrator restir --scenes many-lights
    .venv/bin/python bench/bench_light_sampler.py --scenes lamps-1 lamps-2 lamps-4 lamps-8 lamps-16 lamps-32
"""
from __future__ import annotations

import argparse
import datetime as _dt
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402

import caustica  # noqa: E402
from bench_cornell_depth import ROOT, append_block  # noqa: E402
from caustica._provenance import commit  # noqa: E402

MANY_LIGHTS = os.path.join(ROOT, "tests", "data", "json", "many-lights.json")


def lamps_scene(n: int, w: int, h: int) -> dict:
    """A closed room (4 x 2.5 x 4) with two objects, lit by n small square ceiling lamps on a grid (facing down,
    each 2 triangles, never overlapping), their total power fixed: the scenes "lamps-N" of --scenes, for where the light BVH starts
    to pay."""
    cols = int(np.ceil(np.sqrt(n)))
    rows_ = int(np.ceil(n / cols))
    half = min(0.12, 0.2 * 3.0 / max(cols, rows_))  # lamp half side: at most 40% of the grid's spacing
    radiance = 240.0 / n  # the same total power for every n
    shapes = [
        {"type": "cube", "material": "wall", "transform": {"scale": [2, 1.25, 2], "translate": [0, 1.25, 0]},
         "flip_normals": True},
        {"type": "cube", "material": "box", "transform": {"scale": 0.4, "translate": [0.6, 0.4, -0.4]}},
        {"type": "sphere", "center": [-0.8, 0.5, 0.5], "radius": 0.5, "material": "box"},
    ]
    for k in range(n):
        i, j = k % cols, k // cols
        x = -1.5 + 3.0 * (i + 0.5) / cols
        z = -1.5 + 3.0 * (j + 0.5) / rows_
        shapes.append({"type": "rectangle", "material": "wall", "emission": [radiance] * 3,
                       "transform": {"scale": half, "rotate": {"axis": [1, 0, 0], "angle": 90},
                                     "translate": [x, 2.49, z]}})
    return {"name": f"lamps-{n}",
            "camera": {"position": [0, 1.3, 1.95], "target": [0, 0.9, -1], "up": [0, 1, 0], "fov": 65,
                       "width": w, "height": h},
            "filter": "box",
            "materials": {"wall": {"type": "diffuse", "reflectance": 0.6, "two_sided": True},
                          "box": {"type": "diffuse", "reflectance": [0.7, 0.5, 0.3]}},
            "shapes": shapes}


def relmse(x, ref):
    return float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["many-lights", "cornell", "smallvcm-spheres"])
    ap.add_argument("--size", default="256x192", help="WxH for many-lights and lamps-N (the built-in scenes keep "
                    "theirs)")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--integrator", choices=("path", "restir", "sppm", "bdpt", "vcm"), default="path")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--no-append", action="store_true")
    a = ap.parse_args()
    started = _dt.datetime.now(_dt.timezone.utc)
    com = commit(ROOT)
    w, h = (int(v) for v in a.size.split("x"))
    rows = []
    for name in a.scenes:
        if name == "many-lights":
            scene = caustica.load_scene(MANY_LIGHTS, width=w, height=h)
        elif name.startswith("lamps-"):
            scene = caustica.load_scene(lamps_scene(int(name[6:]), w, h))
        else:
            scene = caustica.load_scene(name)
        ref = caustica.render(scene, spp=a.ref_spp, seed=100003)
        res = {}
        for ls in ("power", "bvh"):
            caustica.render_job(scene, integrator=a.integrator, spp=1, seed=0, light_sampler=ls)  # warm-up
            res[ls] = {"err": [], "t": [], "lanes": 0}
        for seed in range(1, a.seeds + 1):
            for ls in ("power", "bvh"):
                r = caustica.render_job(scene, integrator=a.integrator, spp=a.spp, seed=seed, light_sampler=ls)
                res[ls]["err"].append(relmse(r.image, ref))
                res[ls]["t"].append(float(r.stats["seconds"]))
                res[ls]["lanes"] = r.stats["lanes"]
        e = {ls: float(np.mean(v["err"])) for ls, v in res.items()}
        t = {ls: statistics.median(v["t"]) for ls, v in res.items()}
        ratio = (e["bvh"] * t["bvh"]) / (e["power"] * t["power"])
        label = f"{name} {w}x{h}" if name == "many-lights" or name.startswith("lamps-") else name
        print(f"{label}: power relMSE {e['power']:.4g} in {t['power']:.3f} s (lanes {res['power']['lanes']}), "
              f"bvh relMSE {e['bvh']:.4g} in {t['bvh']:.3f} s (lanes {res['bvh']['lanes']}); time to equal relMSE bvh/power {ratio:.3f}",
              flush=True)
        rows.append([label, str(a.spp), f"{e['power']:.4g}", f"{t['power']:.3f}", str(res["power"]["lanes"]),
                     f"{e['bvh']:.4g}", f"{t['bvh']:.3f}", str(res["bvh"]["lanes"]), f"{e['power'] / e['bvh']:.2f}",
                     f"{ratio:.3f}"])
    if not a.no_append:
        append_block("bench_light_sampler.py", started, com, f"light BVH against the power sampler ({a.integrator})",
                     f"Settings: {a.integrator} (default options), {a.spp} spp, seeds 1..{a.seeds} per sampler (alternating, after a "
                     f"warm-up render each), all threads; relMSE against a path-traced power-sampler reference of "
                     f"{a.ref_spp} spp (its own seed), averaged over the seeds; seconds: median render time. Time to equal "
                     "relMSE bvh / power = (relMSE x seconds) ratio; below 1: the BVH is ahead.",
                     ["scene", "spp", "power relMSE", "power (s)", "power lanes", "bvh relMSE", "bvh (s)",
                      "bvh lanes", "relMSE power / bvh", "time to equal relMSE, bvh / power"], rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
