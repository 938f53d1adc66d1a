#!/usr/bin/env python3
"""pm and ppm on the CPU wavefront (the driver --device cuda runs; pm on the portable kd-tree of
photon/knn_tree.h) against the CPU photon integrator (pm on nanoflann): median pass time of 3 alternating runs
and the largest relative difference between the two images. Prints bench/RESULTS.md rows:
    .venv/bin/python bench/bench_wavefront_pm.py
"""
import caustica, statistics, numpy as np
for scene in ("cornell", "smallvcm-spheres"):
    s = caustica.load_scene(scene, width=256, height=256)
    for integ in ("pm", "ppm"):
        kw = dict(integrator=integ, spp=16, seed=1, photons=200000)
        t = {False: [], True: []}
        for r in range(3):
            for wf in (False, True):
                j = caustica.render_job(s, wavefront=wf, **kw)
                t[wf].append(j.stats["seconds"]); img = j.image
                if wf: a = img
                else: b = img
        rel = float(np.max(np.abs(a - b) / (np.abs(b) + 1e-6)))
        print(f"| {scene} | {integ} | 256x256, 16 passes, 200000 photons | {statistics.median(t[False]):.2f} | {statistics.median(t[True]):.2f} | {statistics.median(t[True])/statistics.median(t[False]):.2f} | {rel:.1e} |", flush=True)
