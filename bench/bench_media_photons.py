#!/usr/bin/env python3
"""Equal-time comparison of the volumetric path tracer, volumetric photon mapping (pppm, sppm, ppm, pm) and light
tracing, bidirectional path tracing, bidirectional photon mapping and vertex connection and merging with medium
vertices (light, bdpt, bpm, vcm) in fog.

Two scenes of tests/python/test_media_photons.py (a point light in a box of fog over a grey floor): `fog-lamp`
(no glass: every integrator renders every path, the reference is the path tracer at high spp) and `fog-lens`
(a glass ball under the light focuses it into the fog: a volumetric caustic through L S S V E paths, which
the path tracer cannot sample from a point light; the reference is a long bdpt render, unbiased; with
--lens-ref pppm a long pppm render as before, consistent but biased at any finite pass count), and
`smoke-lamp` (test_media_grid.py's smoke box: the fog a heterogeneous blob; reference: the path tracer), and
`fog-mirror` (test_media_bidir.py's mirror scene: fog-lens without the floor seen only in a mirror, so the
caustic comes through L S S V S E paths that no connection samples and only merging renders: pppm, sppm, bpm,
vcm; the reference is a long pppm render, consistent but biased at its pass count: pppm's kernels read 2-6%
low at the fog's boundary there; bpm and vcm take --merge-volume-radius there, default their automatic radii). Each
integrator renders each scene for the given seconds (whole passes until the budget is spent) and the script
reports relMSE against the reference. pm builds its maps once (--pm-photons photon paths, --k nearest) within the
budget and spends the rest on camera samples.

usage: .venv/bin/python bench/bench_media_photons.py [--res 64] [--times 1 4 16]
       [--integrators path pppm sppm ppm pm bdpt light bpm vcm] [--scenes fog-lamp fog-lens smoke-lamp fog-mirror]
       [--lens-ref bdpt] [--merge-volume-radius 0] [--pm-photons 200000] [--k 50] [--rows]
"""
import argparse
import datetime
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python"))
sys.path.insert(0, os.path.join(ROOT, "tests", "python"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--times", type=float, nargs="+", default=[1.0, 4.0, 16.0])
    ap.add_argument("--photons", type=int, default=50000, help="pppm photon paths per pass")
    ap.add_argument("--ref-spp", type=int, default=8192, help="fog-lamp reference: path tracer spp")
    ap.add_argument("--ref-passes", type=int, default=1024, help="fog-lens reference: pppm passes")
    ap.add_argument("--lens-ref", choices=["bdpt", "pppm"], default="bdpt",
                    help="fog-lens reference: bdpt at --ref-spp passes (unbiased) or pppm at --ref-passes")
    ap.add_argument("--pm-photons", type=int, default=200000, help="pm: photon paths of its maps")
    ap.add_argument("--k", type=int, default=50, help="pm: photons per estimate")
    ap.add_argument("--integrators", nargs="+", default=["path", "pppm", "sppm"])
    ap.add_argument("--merge-volume-radius", type=float, default=0.0,
                    help="fog-mirror: bpm's and vcm's --volume-radius (0: their automatic ones)")
    ap.add_argument("--scenes", nargs="+", default=["fog-lamp", "fog-lens", "smoke-lamp"])
    ap.add_argument("--rows", action="store_true", help="print bench/RESULTS.md rows")
    a = ap.parse_args()
    import caustica
    from caustica import _provenance
    from conftest import relmse
    from test_media_bidir import in_a_mirror
    from test_media_grid import smoke_box
    from test_media_photons import fog_box

    def mirror():
        s = in_a_mirror(fog_box("glass"))
        s["camera"]["width"] = s["camera"]["height"] = a.res
        return s

    make = {"fog-lamp": lambda: fog_box(width=a.res), "fog-lens": lambda: fog_box("glass", width=a.res),
            "smoke-lamp": lambda: smoke_box(width=a.res), "fog-mirror": mirror}
    ref_of = {"fog-lamp": "path", "smoke-lamp": "path", "fog-lens": a.lens_ref, "fog-mirror": "pppm"}
    scenes = {n: make[n]() for n in a.scenes}

    def reference(name):
        if ref_of[name] == "pppm":
            return caustica.render(scenes[name], integrator="pppm", spp=a.ref_passes, photons=4 * a.photons,
                                   seed=1000, max_depth=-1)
        return caustica.render(scenes[name], integrator=ref_of[name], spp=a.ref_spp, seed=1000, max_depth=-1)

    refs = {n: (ref_of[n], reference(n)) for n in scenes}
    rows = []
    for name, sc in scenes.items():
        for integrator in a.integrators:
            for t in a.times:
                kw = dict(photons=a.photons) if integrator in ("pppm", "sppm", "ppm") else {}
                if integrator == "pm":
                    kw = dict(photons=a.pm_photons, k=a.k)
                if name == "fog-mirror" and integrator in ("bpm", "vcm") and a.merge_volume_radius > 0:
                    kw["volume_radius"] = a.merge_volume_radius
                r = caustica.render_job(sc, integrator=integrator, time=t, seed=7, max_depth=-1, **kw)
                e = relmse(r.image, refs[name][1])
                rows.append((name, integrator, t, r.stats["passes"], r.stats["seconds"], e))
                print(f"{name:9s} {integrator:5s} {t:6.1f} s  {r.stats['passes']:6d} passes  relMSE {e:.5f}",
                      flush=True)
    if a.rows:
        prov = {"commit": _provenance.commit(ROOT), "machine": _provenance.machine()}
        when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        print(f"\n## {when}, commit {prov['commit']}: {', '.join(a.integrators)} in fog and smoke, equal time "
              f"(`bench/bench_media_photons.py`)\n")
        print(f"Machine: {prov['machine']}. Command: `.venv/bin/python bench/bench_media_photons.py --res {a.res} "
              f"--times {' '.join(f'{t:g}' for t in a.times)} --integrators {' '.join(a.integrators)} --scenes "
              f"{' '.join(a.scenes)} --lens-ref {a.lens_ref} --merge-volume-radius {a.merge_volume_radius:g} "
              f"--pm-photons {a.pm_photons} --k {a.k} --rows`; "
              f"{a.res}x{a.res}, {a.photons} photon paths per pass "
              f"(pppm, sppm, ppm; pm's maps {a.pm_photons} paths, k {a.k}; light, bdpt, bpm and vcm one light subpath "
              f"per pixel); references: fog-lamp and "
              f"smoke-lamp path {a.ref_spp} spp, fog-lens "
              + (f"pppm {a.ref_passes} passes of {4 * a.photons} photons" if a.lens_ref == "pppm"
                 else f"bdpt {a.ref_spp} passes")
              + f", fog-mirror pppm {a.ref_passes} passes of {4 * a.photons} photons (seed 1000).\n")
        print("| scene | integrator | seconds | passes | relMSE |")
        print("|---|---|---|---|---|")
        for name, integrator, t, passes, secs, e in rows:
            print(f"| {name} | {integrator} | {secs:.2f} | {passes} | {e:.5f} |")


if __name__ == "__main__":
    main()
