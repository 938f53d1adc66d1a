"""Photon-mapping benchmark: photon paths traced per second and equal-time relMSE of
sppm (and ppm, pppm) against path tracing on the glass-sphere Cornell box
(`smallvcm-spheres`), against a long path-traced reference (cached in bench/out/).

    .venv/bin/python bench/bench_photon.py [--res 128] [--ref-spp 16384] [--budgets 2 8]

Appends a block to bench/RESULTS.md."""
import argparse
import datetime
import os
import subprocess
import sys
import time

import numpy as np

import caustica

HERE = os.path.dirname(os.path.abspath(__file__))


def relmse(x, r):
    return float(np.mean((x - r) ** 2 / (r ** 2 + 0.01)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--ref-spp", type=int, default=16384)
    ap.add_argument("--budgets", type=float, nargs="+", default=[2.0, 8.0])
    ap.add_argument("--photons", type=int, default=100000)
    a = ap.parse_args()
    os.makedirs(os.path.join(HERE, "out"), exist_ok=True)
    scene = caustica.load_scene("smallvcm-spheres", width=a.res, height=a.res)
    ref_path = os.path.join(HERE, "out", f"ref_smallvcm-spheres_{a.res}_{a.ref_spp}.npy")
    if os.path.exists(ref_path):
        ref = np.load(ref_path)
    else:
        t = time.time()
        ref = caustica.render(scene, spp=a.ref_spp, seed=12345).astype(np.float64)
        np.save(ref_path, ref)
        print(f"reference: {a.ref_spp} spp path tracing in {time.time() - t:.1f} s")
    rows = []
    for T in a.budgets:
        for integ in ("path", "sppm", "ppm", "pppm"):
            kw = {} if integ == "path" else {"photons": a.photons}
            r = caustica.render_job(scene, integrator=integ, time=T, seed=1, **kw)
            st = r.stats
            rows.append((T, integ, st["passes"], st["photons"] / st["seconds"] if st["photons"] else 0.0,
                         relmse(r.image, ref)))
            print(rows[-1])
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=HERE).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True,
                           cwd=HERE).stdout.strip()
    model = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    machine = f"{model}, {os.cpu_count()} cores"
    load = os.getloadavg()[0]
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = [f"\n## Photon mapping: equal time on `smallvcm-spheres`, {date}, commit {commit}{'-dirty' if dirty else ''}\n",
             f"Command: `.venv/bin/python bench/bench_photon.py --res {a.res} --ref-spp {a.ref_spp} --budgets "
             f"{' '.join(str(b) for b in a.budgets)} --photons {a.photons}`  ",
             f"Machine: {machine}; load average at the end {load:.2f}. Reference: path tracing, {a.ref_spp} spp, "
             f"{a.res}x{a.res}. relMSE = mean (x - r)^2 / (r^2 + 0.01).\n",
             "| budget (s) | integrator | passes | photon paths/s | relMSE | relMSE / path's |", "|---:|---|---:|---:|---:|---:|"]
    for T in a.budgets:
        base = next(r[4] for r in rows if r[0] == T and r[1] == "path")
        for r in rows:
            if r[0] == T:
                lines.append(f"| {T:g} | {r[1]} | {r[2]} | {r[3] / 1e6:.2f} M | {r[4]:.5f} | {r[4] / base:.3f} |")
    with open(os.path.join(HERE, "RESULTS.md"), "a") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
