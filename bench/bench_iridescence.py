#!/usr/bin/env python3
"""What a KHR_materials_iridescence film costs: bench/scenes/mr_spheres.json against the same scene with a film
on its metal and plastic spheres (material/thin_film.h: 4 cosines and 4 exponentials per Fresnel evaluation), in
the current build, the two alternating in one process so that drifts of the machine's speed hit both alike.
Reports the median render seconds (stats["seconds"]: the passes, not the load) and their ratio, and appends a row
to bench/RESULTS.md unless --no-append (under the table of such rows there, the last lines of the file).

usage: .venv/bin/python bench/bench_iridescence.py [--integrator path] [--spp 16] [--runs 5] [--threads 1]
"""
import argparse
import copy
import datetime
import json
import os
import statistics
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--integrator", default="path")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--no-append", action="store_true")
    a = ap.parse_args()
    import caustica
    from caustica._provenance import commit, machine
    with open(os.path.join(ROOT, "bench", "scenes", "mr_spheres.json")) as f:
        plain = json.load(f)
    film = copy.deepcopy(plain)
    for name, d in (("metal", 550.0), ("plastic", 400.0)):
        film["materials"][name].update(iridescence=1.0, iridescence_eta=1.4, iridescence_thickness=d)
    scenes = {"plain": caustica.load_dict(plain), "film": caustica.load_dict(film)}
    opts = dict(integrator=a.integrator, spp=a.spp, threads=a.threads, seed=1)
    for s in scenes.values():
        caustica.render_job(s, **dict(opts, spp=1))  # warm-up
    times = {"plain": [], "film": []}
    for _ in range(a.runs):
        for k, s in scenes.items():
            times[k].append(caustica.render_job(s, **opts).stats["seconds"])
    tp, tf = statistics.median(times["plain"]), statistics.median(times["film"])
    cmd = "bench/bench_iridescence.py " + " ".join(sys.argv[1:])
    line = (f"film {tf:.3f} s, plain {tp:.3f} s (medians of {a.runs}), film / plain {tf / tp:.3f}")
    print(line)
    if not a.no_append:
        when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        with open(os.path.join(ROOT, "bench", "RESULTS.md"), "a") as f:
            f.write(f"| {when} | {machine()} | {commit(ROOT)} | `{cmd}` "
                    f"(mr_spheres {a.integrator} {a.spp} spp, {a.threads} thread(s)) | {line} |\n")


if __name__ == "__main__":
    main()
