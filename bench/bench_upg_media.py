#!/usr/bin/env python3
"""upg against bdpt in haze and without it: per-pixel variance of a 4-pass image over 8 seeds and the seconds of
those 4 passes (stats["seconds"], median), at 64 x 64 on smallvcm-fog and smallvcm-spheres, upg at its default
radius (one pixel footprint) and at 0.3 (gathers carrying much of the weight). Prints one line per case; the
figures go to bench/RESULTS.md by hand.

Usage: .venv/bin/python bench/bench_upg_media.py
"""
import caustica
import numpy as np

for name in ["smallvcm-fog", "smallvcm-spheres"]:
    sc = caustica.load_scene(name, width=64, height=64, filter="box")
    for integ, kw in [("bdpt", {}), ("upg", {}), ("upg", {"radius": 0.3})]:
        imgs, secs = [], []
        for s in range(8):
            r = caustica.render_job(sc, integrator=integ, spp=4, max_depth=-1, seed=s, **kw)
            imgs.append(r.image[..., :3].astype(np.float64)); secs.append(r.stats["seconds"])
        imgs = np.array(imgs)
        var = imgs.var(axis=0, ddof=1).mean()  # per-pixel variance of a 4-pass image
        t = float(np.median(secs))
        label = integ + (" r=%.2g" % kw["radius"] if kw else " r=auto")
        print(f"{name} {label} mean {imgs.mean():.4f} var(4 passes) {var:.3e}  s/4 passes {t:.3f}  "
              f"var*time {var * t:.3e}", flush=True)
