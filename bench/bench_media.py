#!/usr/bin/env python3
"""Single scattering of a point light in fog: error against the analytic answer, per build.

The scene of tests/python/test_media.py::test_single_scattering_of_a_point_light_matches_quadrature, larger:
a camera inside an infinite homogeneous medium, a point light in view, max_depth 2, no pixel jitter, so every
pixel's expected value is a 1D integral along its centre ray, computed by quadrature. For each build given
(a folder from bench/bench_ab.py --save, or 'current'), in its own process, the script renders the scene at
the given spp (several seeds) and reports the time and relMSE against that reference; relMSE x time compares
estimators (constant for an unbiased 1/N estimator). Media without equiangular sampling (free-flight sampling
and NEE alone) against media with it is the comparison this was written for.

usage: .venv/bin/python bench/bench_media.py --build /tmp/ab/before --build current [--spp 16] [--res 64]
       [--sigma-s 0.05] [--rows]
"""
import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python"))
sys.path.insert(0, os.path.join(ROOT, "tests", "python"))

CHILD = r"""
import json, sys, time
if sys.argv[1] != "current":  # that folder's caustica, not the editable install's
    sys.meta_path = [f for f in sys.meta_path if "editable" not in type(f).__module__.lower()]
    sys.path.insert(0, sys.argv[1])
import numpy as np
import caustica
case = json.loads(sys.argv[2])
imgs, secs = [], 0.0
for seed in case["seeds"]:
    r = caustica.render_job(case["scene"], spp=case["spp"], seed=seed, **case["kwargs"])
    imgs.append(r.image)
    secs += r.stats["seconds"]
np.save(sys.argv[3], np.stack(imgs))
print(json.dumps({"seconds": secs / len(case["seeds"])}))
"""


def build_arguments(res):
    """The arguments of the benches that time builds against each other (this one, bench_media_emission.py):
    --build (repeated), --spp, --res (default `res`), --seeds and --rows."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", action="append", required=True, help="a folder from bench_ab.py --save, or 'current'")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--res", type=int, default=res)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--rows", action="store_true", help="print bench/RESULTS.md rows")
    return ap


def run_build(build, scene, spp, seeds, **kwargs):
    """Renders `scene` with `build` (a folder from bench_ab.py --save, or 'current') in a process of its own,
    once per seed: (mean seconds per render, images seeds x H x W x 3)."""
    case = {"scene": scene, "spp": spp, "seeds": list(seeds), "kwargs": kwargs}
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "img.npy")
        r = subprocess.run([sys.executable, "-c", CHILD, build, json.dumps(case), out], capture_output=True,
                           text=True)
        if r.returncode != 0:
            err = r.stderr.strip()
            sys.exit(f"build {build}: " + (err.splitlines()[-1] if err else str(r.returncode)))
        return json.loads(r.stdout.strip().splitlines()[-1])["seconds"], np.load(out).astype(np.float64)


def scene(res, sigma_a, sigma_s, g):
    return {
        "camera": {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov": 60, "width": res,
                   "height": res, "medium": "fog"},
        "media": {"fog": {"sigma_a": sigma_a, "sigma_s": sigma_s, "g": g}},
        "materials": {"black": {"type": "diffuse", "reflectance": 0.0}},
        "shapes": [{"type": "sphere", "center": [0, 0, 50], "radius": 0.1, "material": "black"}],
        "lights": [{"type": "point", "position": [0.3, 0.2, -2.0], "intensity": [5.0, 4.0, 3.0]}],
    }


def main():
    ap = build_arguments(64)
    ap.add_argument("--sigma-a", type=float, default=0.01)
    ap.add_argument("--sigma-s", type=float, default=0.05)
    ap.add_argument("--g", type=float, default=0.3)
    a = ap.parse_args()
    from test_media import single_scattering_reference
    from caustica import _provenance
    res = a.res
    sc = scene(res, a.sigma_a, a.sigma_s, a.g)
    lamp = sc["lights"][0]
    ref = np.zeros((res, res, 3))
    tan_half = np.tan(np.radians(30))
    for y in range(res):
        for x in range(res):
            d = np.array([(2 * (x + 0.5) / res - 1) * tan_half, (1 - 2 * (y + 0.5) / res) * tan_half, -1.0])
            ref[y, x] = single_scattering_reference(d / np.linalg.norm(d), np.array(lamp["position"]),
                                                    lamp["intensity"], a.sigma_a, a.sigma_s, a.g, n=4000)
    rows = []
    for b in a.build:
        t, imgs = run_build(b, sc, a.spp, range(1, a.seeds + 1), max_depth=2, jitter=False)
        rel = float(np.mean([np.mean((im - ref) ** 2 / (ref ** 2 + 1e-4)) for im in imgs]))
        bias = float((imgs.mean(axis=0) - ref).mean() / ref.mean())
        print(f"{b}: {a.spp} spp, {t:.3f} s, relMSE {rel:.3g}, relMSE x time {rel * t:.3g}, mean bias {bias:+.4f}")
        rows.append((b, t, rel))
    if a.rows:
        commit = _provenance.commit(ROOT)
        machine = _provenance.machine()
        base = rows[0][1] * rows[0][2]
        for b, t, rel in rows:
            print(f"| {datetime.date.today()} | {machine} | {commit} | `bench/bench_media.py --spp {a.spp} --res {res} "
                  f"--sigma-s {a.sigma_s} --sigma-a {a.sigma_a} --g {a.g}` | {b}: {t:.3f} s, relMSE {rel:.3g}, "
                  f"relMSE x time {rel * t / base:.3g} of the first build's |")


if __name__ == "__main__":
    main()
