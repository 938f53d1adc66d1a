#!/usr/bin/env python3
"""Emissive grid media: the path tracer's error against a reference, per build.

The scene: the glowing plume of docs/scene-format.md (tests/data/media/plume.vdb: density, a `Cd` albedo grid
and blackbody emission from the density read as hundreds of kelvin) over a floor under a dim sky, the camera
outside its null box. For each build given (a folder from bench/bench_ab.py --save, or 'current'), in its own
process, the script renders the scene with `path` at the given spp (several seeds) and reports the time and
the relMSE against a reference (the current build at --ref-spp); relMSE x time compares estimators (constant
for an unbiased 1/N estimator). Written to weigh emission scored at real collisions only (medium/medium.h's
collision estimator) against emission scored at every tentative collision of the delta-tracking walk, as
pbrt-v4 does (bench/RESULTS.md, 2026-12-05: not adopted); --sigma-t thins the plume.

usage: .venv/bin/python bench/bench_media_emission.py --build /tmp/ab/before --build current [--spp 16]
       [--res 96] [--seeds 4] [--ref-spp 2048] [--integrator path] [--sigma-t 3] [--rows]
"""
import datetime
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python"))
sys.path.insert(0, os.path.join(ROOT, "tests", "python"))
sys.path.insert(0, os.path.join(ROOT, "bench"))

def plume(res, sigma_t=3.0):
    vdb = os.path.join(ROOT, "tests", "data", "media", "plume.vdb")
    return {
        "camera": {"position": [0, 1.2, 4], "target": [0, 1, 0], "width": res, "height": res},
        "media": {"fire": {"type": "heterogeneous", "sigma_t": sigma_t, "g": 0.2, "density": {"file": vdb},
                           "albedo": {"file": vdb, "grid": "Cd"},
                           "emission": {"file": vdb, "grid": "density",
                                        "blackbody": {"temperature_scale": 1000, "scale": 4}}}},
        "materials": {"bound": {"type": "null"}, "floor": {"type": "diffuse", "reflectance": 0.5}},
        "shapes": [{"type": "cube", "material": "bound", "interior": "fire",
                    "transform": {"scale": [1.2, 1.4, 1.2], "translate": [0, 1.3, 0]}},
                   {"type": "rectangle", "material": "floor",
                    "transform": {"scale": 4, "rotate": {"axis": [1, 0, 0], "angle": -90}}}],
        "lights": [{"type": "environment", "radiance": 0.05}],
    }


def main():
    from bench_media import build_arguments, run_build
    ap = build_arguments(96)
    ap.add_argument("--ref-spp", type=int, default=2048)
    ap.add_argument("--integrator", default="path")
    ap.add_argument("--sigma-t", type=float, default=3.0, help="sigma_t per unit density (the docs' 3; lower: thinner)")
    a = ap.parse_args()
    from caustica import _provenance
    from conftest import relmse
    scene = plume(a.res, a.sigma_t)
    ref = run_build("current", scene, a.ref_spp, [1000], integrator="path", max_depth=-1)[1][0]
    rows = []
    for build in a.build:
        secs, imgs = run_build(build, scene, a.spp, range(1, a.seeds + 1), integrator=a.integrator, max_depth=-1)
        e = float(np.mean([relmse(im, ref) for im in imgs]))
        rows.append((build, secs, e))
        print(f"{build}: {a.integrator} {a.spp} spp {secs:.3f} s  relMSE {e:.5f}  relMSE x time {e * secs:.6f}",
              flush=True)
    if a.rows:
        prov = {"commit": _provenance.commit(ROOT), "machine": _provenance.machine()}
        when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        print(f"\n## {when}, commit {prov['commit']}: emissive grid medium (`bench/bench_media_emission.py`)\n")
        print(f"Machine: {prov['machine']}. Command: `.venv/bin/python bench/bench_media_emission.py "
              + " ".join(f"--build {b}" for b in a.build)
              + f" --spp {a.spp} --res {a.res} --seeds {a.seeds} --ref-spp {a.ref_spp} --integrator {a.integrator}"
              f" --sigma-t {a.sigma_t:g}"
              f" --rows`; the docs' plume (tests/data/media/plume.vdb), reference: path {a.ref_spp} spp with the "
              f"current build (seed 1000); relMSE the mean over {a.seeds} seeds.\n")
        print("| build | integrator | spp | seconds | relMSE | relMSE x seconds |")
        print("|---|---|---|---|---|---|")
        for build, secs, e in rows:
            print(f"| {build} | {a.integrator} | {a.spp} | {secs:.3f} | {e:.5f} | {e * secs:.6f} |")


if __name__ == "__main__":
    main()
