#!/usr/bin/env python3
"""Photon integrators on the CPU wavefront (the driver --device cuda runs; pm on the portable kd-tree of
photon/knn_tree.h, adaptive photon tracing one thread per chain) against the CPU photon integrator (pm on
nanoflann): median pass time of 3 alternating runs and the largest relative difference between the two
images. Integrators from the command line (default pm and ppm; variants such as sppm+adaptive too). Prints
bench/RESULTS.md rows:
    .venv/bin/python bench/bench_wavefront_pm.py [INTEGRATOR ...]
"""
import statistics
import sys

import numpy as np

import caustica
from caustica import _api

for scene in ("cornell", "smallvcm-spheres"):
    s = caustica.load_scene(scene, width=256, height=256)
    for name in sys.argv[1:] or ["pm", "ppm"]:
        integ, variant = _api.split_integrator_variant(name)
        kw = dict(integrator=integ, spp=16, seed=1, photons=200000, **variant)
        t = {False: [], True: []}
        for r in range(3):
            for wf in (False, True):
                j = caustica.render_job(s, wavefront=wf, **kw)
                t[wf].append(j.stats["seconds"]); img = j.image
                if wf: a = img
                else: b = img
        rel = float(np.max(np.abs(a - b) / (np.abs(b) + 1e-6)))
        print(f"| {scene} | {name} | 256x256, 16 passes, 200000 photons | {statistics.median(t[False]):.2f} | {statistics.median(t[True]):.2f} | {statistics.median(t[True])/statistics.median(t[False]):.2f} | {rel:.1e} |", flush=True)
