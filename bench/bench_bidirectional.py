#!/usr/bin/env python3
"""Equal-time relMSE of caustica's bidirectional integrators (`bdpt`, `vcm`, and `upg` when it exists) against
`path` and `sppm`, and against SmallVCM's `bpt` and `vcm`, on SmallVCM's four Cornell-box scenes.

SmallVCM (github.com/SmallVCM/SmallVCM, MIT licence) is not part of this repository and nothing of it is
committed here: build it outside the tree (bench/smallvcm/README.md) and pass its binary with --smallvcm
(default /tmp/smallvcm/smallvcm). The SmallVCM driver, scene table, HDR reader and machine/load helpers are
those of bench/bench_smallvcm.py, imported from it.

Scenes: caustica's `smallvcm-sun`, `smallvcm-mirror-ball`, `smallvcm-point`, `smallvcm-env` = SmallVCM's
`-s 0..3` (512 x 512, box filter, at most 10 segments; shared/scenes/smallvcm-scenes.md). Both renderers use
all cores (SmallVCM: one OpenMP renderer per processor; caustica: threads=0) at 512 x 512.

What it does:
  1. References: caustica `vcm` (connections and merging: every light path of these scenes, including the
     caustics of the point and directional lights seen in the mirror, which `bdpt` and `path` cannot sample),
     two independent long renders (seeds 1000003 and 1000004, --ref-seconds / 2 each), averaged. Cached in
     bench/out/bidirectional/ with a JSON sidecar (scene, integrator, passes and seconds of each half, seeds,
     radius, commit, date); the noise of the average is estimated as relMSE(half A, half B) / 4 (the two halves
     have the same radius schedule, so their difference is noise only; averaging halves the variance).
  2. Agreement check: SmallVCM's own long `vcm` render (the cached reference of bench_smallvcm.py, rendered
     if missing) against caustica's reference: relMSE and image means, with both references' noise estimates,
     so a reader can see that the two programs render the same scenes.
  3. Equal time: per scene, SmallVCM `bpt` and `vcm` wall time per iteration is measured (runs of 2 and 6
     iterations: slope and fixed cost); for each budget B SmallVCM runs -i N (N even: 2 OpenMP threads)
     chosen to fill B and its wall time W (process start to exit) is measured; caustica then renders with
     time=W in this process (scene loaded and warmed up beforehand): `bdpt` with W of SmallVCM `bpt`; `vcm`,
     `path`, `sppm` (and `upg`) with W of SmallVCM `vcm`. caustica's `time` stops after the pass that crosses
     W, so its render seconds are given too. Every render records /proc/loadavg before and after and the CPU
     other work took meanwhile (/proc/stat less this process's and its children's CPU).
  4. Errors: relMSE = mean over pixels and channels of (x - r)^2 / (r^2 + 0.01) against the caustica
     reference; ratio = relMSE(caustica) / relMSE(SmallVCM) for vcm/vcm and bdpt/bpt (below 1: caustica
     better); the same with the reference's noise subtracted from both. `bdpt`/`bpt` cannot sample
     L S+ D S+ E paths from the point light and the sun (scenes 0 and 2): both then converge to an image
     darker than the reference in the same places, and their relMSE includes that common bias.

`upg` (unbiased photon gathering) is not in the default set: a time-limited caustica render completes at least
one pass, and one `upg` pass at 512 x 512 (smallvcm-sun) had not finished after 4 minutes on the 2-core
machine (its 1/P trial rays), so it cannot be compared at budgets of seconds; `--integrators
path,sppm,bdpt,vcm,upg` includes it anyway.

Usage:
  .venv/bin/python bench/bench_bidirectional.py                    # full run, appends a block to RESULTS.md
  .venv/bin/python bench/bench_bidirectional.py --refs-only        # only make/cache the references
  .venv/bin/python bench/bench_bidirectional.py --scenes 2 --budgets 5 --ref-seconds 40 --no-results   # smoke
"""
from __future__ import annotations

import argparse
import datetime
import glob
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bench_smallvcm as bs  # noqa: E402  (SmallVCM driver, scenes, rel_mse, machine/commit/load helpers)

OUT = os.path.join(bs.ROOT, "bench", "out", "bidirectional")
REF_SEEDS = (1_000_003, 1_000_004)
SV_ALGS = ("bpt", "vcm")
# caustica integrator -> the SmallVCM algorithm whose wall time it gets (and its peer, if any)
TIME_OF = {"path": "vcm", "sppm": "vcm", "bdpt": "bpt", "vcm": "vcm", "upg": "vcm"}
PEER = {"bdpt": "bpt", "vcm": "vcm"}


def proc_loadavg() -> str:
    try:
        with open("/proc/loadavg") as f:
            return " ".join(f.read().split()[:3])
    except OSError:
        return "?"


class Meter:
    """/proc/loadavg before and after, and other work's cores (machine busy CPU less our own) in between."""

    def __enter__(self):
        self.load0 = proc_loadavg()
        self.busy0, self.own0, self.t0 = bs.cpu_busy_seconds(), bs.own_cpu_seconds(), time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.wall = time.perf_counter() - self.t0
        self.other = ((bs.cpu_busy_seconds() - self.busy0) - (bs.own_cpu_seconds() - self.own0)) / max(self.wall,
                                                                                                        1e-9)
        self.load1 = proc_loadavg()
        return False

    def record(self) -> dict:
        return {"load_before": self.load0, "load_after": self.load1, "other_cores": self.other}


# ----------------------------------------------------------------------------------------------- references
def caustica_reference(caustica, scene: int, seconds: float, new: bool = False) -> dict:
    """caustica vcm reference (average of two seeds), cached; the cached one with the most passes is reused."""
    os.makedirs(OUT, exist_ok=True)
    cached = []
    for p in glob.glob(os.path.join(OUT, f"ref_s{scene}_vcm_p*.json")):
        with open(p) as f:
            m = json.load(f)
        if os.path.exists(m["npy"]):
            cached.append(m)
    cached.sort(key=lambda m: m["passes_total"])
    if cached and not new:
        m = cached[-1]
        bs.log(f"  scene {scene}: cached caustica vcm reference, {m['passes_total']} passes")
        m["image"] = np.load(m["npy"])
        return m
    sc = caustica.load_scene(bs.SCENES[scene])
    halves, meta = [], []
    for seed in REF_SEEDS:
        with Meter() as mt:
            r = caustica.render_job(sc, integrator="vcm", time=seconds / 2, seed=seed)
        halves.append(np.asarray(r.image, dtype=np.float64))
        meta.append({"seed": seed, "passes": int(r.stats["passes"]), "seconds": float(r.stats["seconds"]),
                     "radius": float(r.stats.get("radius", float("nan"))), **mt.record()})
        bs.log(f"  scene {scene}: reference half seed {seed}: {meta[-1]}")
    # equal passes are not guaranteed (time-limited): weight the halves by their pass counts
    n0, n1 = meta[0]["passes"], meta[1]["passes"]
    img = (halves[0] * n0 + halves[1] * n1) / (n0 + n1)
    noise = bs.rel_mse(halves[0], halves[1]) * n0 * n1 / (n0 + n1) ** 2   # var_a = c/n0, var_b = c/n1
    npy = os.path.join(OUT, f"ref_s{scene}_vcm_p{n0 + n1}.npy")
    np.save(npy, img.astype(np.float32))
    m = {"scene": scene, "scene_name": bs.SCENES[scene], "integrator": "vcm", "halves": meta,
         "passes_total": n0 + n1, "noise_relmse": noise, "npy": npy, "mean": float(img.mean()),
         "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
         "commit": bs.commit(), "machine": bs.machine(), "resolution": list(img.shape[:2])}
    with open(npy[:-4] + ".json", "w") as f:
        json.dump(m, f, indent=1)
    m["image"] = img.astype(np.float32)
    return m


# ----------------------------------------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--smallvcm", default="/tmp/smallvcm/smallvcm", help="SmallVCM binary")
    ap.add_argument("--scenes", default="0,1,2,3", help="SmallVCM scene ids (-s)")
    ap.add_argument("--budgets", default="10,30", help="wall-time budgets in seconds")
    ap.add_argument("--integrators", default="path,sppm,bdpt,vcm",
                    help="caustica integrators (path, sppm, bdpt, vcm, upg; one not in caustica.integrators() is "
                         "skipped and named). upg is not in the default set: one pass at 512 x 512 takes minutes "
                         "(its 1/P trials), far beyond these budgets")
    ap.add_argument("--ref-seconds", type=float, default=240.0, help="wall time of each new caustica reference")
    ap.add_argument("--sv-ref-seconds", type=float, default=150.0,
                    help="wall time of a SmallVCM long vcm render if none is cached")
    ap.add_argument("--new-ref", action="store_true", help="render new caustica references")
    ap.add_argument("--refs-only", action="store_true", help="make the references and the agreement check only")
    ap.add_argument("--seed", type=int, default=1, help="caustica seed of the equal-time renders")
    ap.add_argument("--no-results", action="store_true", help="do not append to bench/RESULTS.md")
    ap.add_argument("--note", default="", help="text appended to the block in RESULTS.md")
    ap.add_argument("--combine", nargs="+", metavar="RUN_JSON",
                    help="write one block from earlier runs' JSON files (bench/out/bidirectional/run-*.json) "
                         "instead of rendering: for each scene and budget the rows of the last file that has "
                         "them (re-runs of noisy points replace the first run's)")
    a = ap.parse_args(argv)
    if a.combine:
        return combine(a.combine, a.no_results, a.note)

    import caustica

    scenes = [int(s) for s in a.scenes.split(",") if s.strip()]
    budgets = [float(b) for b in a.budgets.split(",") if b.strip()]
    available = caustica.integrators()
    wanted = [i.strip() for i in a.integrators.split(",") if i.strip()]
    integrators = [i for i in wanted if i in available]
    missing = [i for i in wanted if i not in available]
    if not os.path.exists(a.smallvcm):
        ap.error(f"{a.smallvcm} not found: build SmallVCM first (bench/smallvcm/README.md)")

    started = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    com, mach = bs.commit(), bs.machine()
    cmdline = ".venv/bin/python bench/bench_bidirectional.py" + (
        "" if (argv is None and len(sys.argv) == 1) else " " + " ".join(sys.argv[1:] if argv is None else argv))
    bs.log(f"{started}; {mach}; commit {com}; /proc/loadavg {proc_loadavg()}; integrators {integrators}"
           + (f"; not available: {missing}" if missing else ""))
    sv = bs.SmallVCM(a.smallvcm)
    bs.log(f"SmallVCM binary {sv.binary} (sha256 {sv.hash}...)")

    # 1.-2. references and agreement
    refs, agree = {}, {}
    for s in scenes:
        refs[s] = caustica_reference(caustica, s, a.ref_seconds, a.new_ref)
        svr = bs.reference(sv, s, a.sv_ref_seconds, noise=True)
        agree[s] = {"svcm_iterations": svr["iterations"], "svcm_noise": svr.get("noise_relmse"),
                    "caustica_passes": refs[s]["passes_total"], "caustica_noise": refs[s]["noise_relmse"],
                    "relmse": bs.rel_mse(svr["image"], refs[s]["image"]),
                    "svcm_mean": float(svr["image"].mean()), "caustica_mean": float(refs[s]["image"].mean()),
                    "svcm_mean_rgb": [float(x) for x in svr["image"].reshape(-1, 3).mean(0)],
                    "caustica_mean_rgb": [float(x) for x in refs[s]["image"].reshape(-1, 3).mean(0)]}
        bs.log(f"  agreement scene {s}: {agree[s]}")
    if a.refs_only:
        return 0

    # 3. equal time
    rows = []
    for s in scenes:
        ref, nz = refs[s]["image"], refs[s]["noise_relmse"]
        sc = caustica.load_scene(bs.SCENES[s])
        for i in integrators:                                   # warm-up (first-use costs), one pass each
            caustica.render_job(sc, integrator=i, spp=1, seed=a.seed)
        cal = {}
        for alg in SV_ALGS:
            with Meter() as mt:
                cal[alg] = sv.per_iteration(s, alg, 2, 6)
            bs.log(f"scene {s} ({bs.SCENES[s]}): SmallVCM {alg} {cal[alg][0]:.3f} s/iteration + "
                   f"{cal[alg][1]:.3f} s fixed (load {mt.load0} -> {mt.load1}, other {mt.other:.2f} cores)")
        for b in budgets:
            wall = {}
            for alg in SV_ALGS:
                slope, fixed = cal[alg]
                n = bs.even((b - fixed) / slope)
                with Meter() as mt:
                    img, w = sv.render(s, alg, n)
                wall[alg] = w
                e = bs.rel_mse(img, ref)
                row = {"scene": s, "budget": b, "renderer": "SmallVCM", "integrator": alg, "passes": n,
                       "seconds": w, "time_given": None, "relmse": e, "mean": float(img.mean()),
                       "ref_mean": float(ref.mean()), "per_second": n / w, **mt.record()}
                rows.append(row)
                bs.log(f"  {b:g} s: SmallVCM {alg}: {n} iterations in {w:.2f} s, relMSE {e:.5f}, mean "
                       f"{row['mean']:.4f} (ref {row['ref_mean']:.4f}); load {mt.load0} -> {mt.load1}, "
                       f"other {mt.other:.2f} cores")
            for i in integrators:
                t = wall[TIME_OF[i]]
                with Meter() as mt:
                    r = caustica.render_job(sc, integrator=i, time=t, seed=a.seed)
                e = bs.rel_mse(r.image, ref)
                row = {"scene": s, "budget": b, "renderer": "caustica", "integrator": i,
                       "passes": int(r.stats["passes"]), "seconds": float(r.stats["seconds"]), "time_given": t,
                       "relmse": e, "mean": float(np.asarray(r.image).mean()), "ref_mean": float(ref.mean()),
                       "per_second": int(r.stats["passes"]) / max(float(r.stats["seconds"]), 1e-9),
                       "rays": int(r.stats.get("rays", 0)), "shadow_rays": int(r.stats.get("shadow_rays", 0)),
                       "radius": float(r.stats.get("radius", float("nan"))), **mt.record()}
                if i in PEER:
                    peer = next(x for x in rows if x["scene"] == s and x["budget"] == b
                                and x["renderer"] == "SmallVCM" and x["integrator"] == PEER[i])
                    row["ratio"] = e / peer["relmse"]
                    if e > nz and peer["relmse"] > nz:
                        row["ratio_denoised"] = (e - nz) / (peer["relmse"] - nz)
                rows.append(row)
                bs.log(f"    caustica {i}: {row['passes']} passes in {row['seconds']:.2f} s (given {t:.2f}), "
                       f"relMSE {e:.5f}, mean {row['mean']:.4f}"
                       + (f", ratio {row['ratio']:.3f}" if "ratio" in row else "")
                       + f"; load {mt.load0} -> {mt.load1}, other {mt.other:.2f} cores")

    os.makedirs(OUT, exist_ok=True)
    stamp = started.replace("-", "").replace(" ", "-").replace(":", "")[:13]
    js = os.path.join(OUT, f"run-{stamp}.json")
    with open(js, "w") as f:
        json.dump({"started": started, "commit": com, "machine": mach, "command": cmdline, "rows": rows,
                   "smallvcm_sha256_16": sv.hash,
                   "agreement": agree, "missing": missing,
                   "refs": {s: {k: v for k, v in m.items() if k != "image"} for s, m in refs.items()}}, f, indent=1)
    block = format_block(started, mach, com, cmdline, sv, refs, agree, rows, budgets, missing, a.note)
    print(block)
    if not a.no_results:
        with open(bs.RESULTS, "a") as f:
            f.write(block)
        bs.log(f"appended to {bs.RESULTS}; JSON {js}")
    return 0


def combine(paths, no_results: bool, note: str) -> int:
    runs = []
    for p in paths:
        with open(p) as f:
            runs.append(json.load(f))
    points = {}                                         # (scene, budget) -> (run index, rows)
    for k, run in enumerate(runs):
        for r in run["rows"]:
            key = (r["scene"], r["budget"])
            if key not in points or points[key][0] < k:
                points[key] = (k, [])
            if points[key][0] == k:
                points[key][1].append(dict(r, run=run["started"]))
    rows = [r for key in sorted(points) for r in points[key][1]]
    last = runs[-1]
    refs = {int(s): m for run in runs for s, m in run["refs"].items()}
    agree = {int(s): g for run in runs for s, g in run["agreement"].items()}
    budgets = sorted({r["budget"] for r in rows})
    cmd = "; ".join(run["command"] for run in runs) + " (combined with `--combine` of their JSON files)"
    commits = sorted({run["commit"] for run in runs})

    class _SV:   # runs written before the hash was stored: hash the default binary, if it is still there
        hash = last.get("smallvcm_sha256_16") or (bs.sha256("/tmp/smallvcm/smallvcm")
                                                   if os.path.exists("/tmp/smallvcm/smallvcm") else "?")
    block = format_block(" / ".join(run["started"] for run in runs), last["machine"], ", ".join(commits), cmd,
                         _SV, refs, agree, rows, budgets, last.get("missing", []), note)
    print(block)
    if not no_results:
        with open(bs.RESULTS, "a") as f:
            f.write(block)
    return 0


def format_block(started, mach, com, cmdline, sv, refs, agree, rows, budgets, missing, note) -> str:
    L = ["", "", f"## {started}, commit {com}: bidirectional integrators vs `path`, `sppm` and SmallVCM "
         "`bpt`/`vcm`, equal wall time", ""]
    L.append(f"Command: `{cmdline}`  ")
    L.append(f"Machine: {mach}. Both renderers at 512 × 512 with all {os.cpu_count()} cores (SmallVCM: one "
             f"OpenMP renderer per processor, `-i N`, N even; caustica: `render_job(scene, integrator, time=W, "
             f"seed=1)`, threads=0, defaults otherwise). SmallVCM binary sha256 {sv.hash}… (built outside the "
             "tree, bench/smallvcm/README.md).  ")
    L.append("Equal time: W = SmallVCM's measured wall time for the budget (its whole process); caustica `bdpt` "
             "gets W of `bpt`, the others W of `vcm`; caustica stops after the pass that crosses W (its render "
             "seconds are given).  ")
    desc = []
    for s, m in refs.items():
        h = m["halves"]
        desc.append(f"scene {s}: {m['passes_total']} passes ({h[0]['seconds']:.0f} + {h[1]['seconds']:.0f} s, "
                    f"r₁ {h[0]['radius']:.4f}), noise ≈ {m['noise_relmse']:.1e}")
    L.append("Reference: caustica `vcm`, two seeds averaged (bench/out/bidirectional/, JSON sidecars): "
             + "; ".join(desc) + ". Noise = relMSE between the two halves scaled to their average.  ")
    ag = []
    for s, g in agree.items():
        ag.append(f"scene {s}: relMSE {g['relmse']:.4f} (noise SmallVCM ≈ {g['svcm_noise']:.4f} + caustica ≈ "
                  f"{g['caustica_noise']:.4f}), mean {g['svcm_mean']:.4f} vs {g['caustica_mean']:.4f}")
    L.append("Agreement: SmallVCM's long `vcm` render (bench/out/smallvcm/) against caustica's reference: "
             + "; ".join(ag) + ".  ")
    if missing:
        L.append(f"Not run: {', '.join(missing)} (not in `caustica.integrators()` at this commit).  ")
    L.append("")
    multi = len({r.get("run") for r in rows}) > 1
    L.append("| scene | budget (s) | renderer | integrator | passes / iterations | seconds | passes/s | relMSE "
             "| relMSE − ref. noise | caustica / SmallVCM | same, ref. noise subtracted | mean (ref) | loadavg before → after | other cores |"
             + (" run |" if multi else ""))
    L.append("|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---|---|---:|" + ("---|" if multi else ""))
    for r in rows:
        nz = refs[r["scene"]]["noise_relmse"]
        ratio = f"**{r['ratio']:.3f}**" if "ratio" in r else ""
        rd = f"{r['ratio_denoised']:.3f}" if "ratio_denoised" in r else ""
        L.append(f"| {r['scene']} {bs.SCENES[r['scene']]} | {r['budget']:g} | {r['renderer']} | {r['integrator']} | "
                 f"{r['passes']} | {r['seconds']:.2f} | {r['per_second']:.2f} | {r['relmse']:.5f} | "
                 f"{r['relmse'] - nz:.5f} | {ratio} | {rd} | {r['mean']:.4f} ({r['ref_mean']:.4f}) | "
                 f"{r['load_before']} → {r['load_after']} | {r['other_cores']:.2f} |"
                 + (f" {r.get('run', '')} |" if multi else ""))
    L.append("")
    if note:
        L.append(note)
        L.append("")
    return "\n".join(L)


if __name__ == "__main__":
    sys.exit(main())
