#!/usr/bin/env python3
"""Equal-time comparison of caustica's photon mappers with SmallVCM's `ppm` on SmallVCM's four scenes.

SmallVCM (github.com/SmallVCM/SmallVCM, MIT licence) is not part of this repository and nothing of it is
committed here: build it outside the tree (see bench/smallvcm/README.md) and pass its binary with
--smallvcm (default /tmp/smallvcm/smallvcm).

Scenes: caustica's built-ins `smallvcm-sun`, `smallvcm-mirror-ball`, `smallvcm-point`, `smallvcm-env` are
SmallVCM's `-s 0`, `-s 1`, `-s 2`, `-s 3` (512 x 512, box filter, path length 10 segments; see
shared/scenes/smallvcm-scenes.md).

What it does:
  1. References: one long SmallVCM `vcm` render per scene (vertex connection and merging: handles every light
     path, including caustics from the point and directional lights that path tracing cannot sample;
     consistent). The iteration count is chosen from a measured per-iteration wall time to fill
     --ref-seconds. Cached in bench/out/smallvcm/ (gitignored): the cached reference with the most
     iterations is reused unless --new-ref. SmallVCM's seeds are fixed (1234 + thread index), so every SmallVCM run
     replays the same random streams; the noise of a reference of N iterations is estimated from a second
     render of N/4 iterations, whose samples are (nearly) a subset of the N-iteration render:
     relMSE(ref_N/4, ref_N) ~ var_N/4 - var_N = 3 var_N.
  2. Optional check that both programs render the same scene (--path-check-seconds): caustica `path` on the
     scenes path tracing renders completely (1: area light, 3: environment), relMSE and mean against the
     SmallVCM reference.
  3. Equal time: per scene, SmallVCM `ppm`'s wall time per iteration is measured (runs of 4 and 12
     iterations: slope and fixed cost); for each budget B, SmallVCM runs -i N (N even: 2 OpenMP threads)
     with N chosen to fill B, its wall time W is measured (process start to exit, HDR written), and each
     caustica configuration then renders with time=W in the same process (scene loaded beforehand). SmallVCM's
     -t is not used: it counts CPU time summed over threads. Errors: relMSE = mean over pixels and channels
     of (x - r)^2 / (r^2 + 0.01) against the reference; ratio = relMSE(caustica) / relMSE(SmallVCM) at equal
     wall time (below 1: caustica better).

SmallVCM's .hdr is flat (uncompressed) RGBE, first scanline = top of the image (raster (0,0) top-left, as in
caustica); its writer truncates the mantissa, so the reader decodes (m + 0.5) 2^(e-136) as Ward's rgbe.c does,
except that a zero mantissa decodes to 0 (a channel with no light, like the sun's blue, stays black).

Usage:
  .venv/bin/python bench/bench_smallvcm.py                      # full run, appends a block to bench/RESULTS.md
  .venv/bin/python bench/bench_smallvcm.py --budgets 2 --scenes 2 --ref-seconds 20 --no-results   # smoke test
"""
from __future__ import annotations

import argparse
import datetime
import glob
import hashlib
import json
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "bench", "out", "smallvcm")
RESULTS = os.path.join(ROOT, "bench", "RESULTS.md")

SCENES = {0: "smallvcm-sun", 1: "smallvcm-mirror-ball", 2: "smallvcm-point", 3: "smallvcm-env"}
SCENE_NOTE = {0: "sun", 1: "mirror ball, area light", 2: "point light", 3: "environment"}
SVCM_R0 = 0.003 * 2.217060        # SmallVCM: 0.003 x scene radius
SVCM_ALPHA = 0.75
PHOTONS = 512 * 512               # photon paths per pass, as SmallVCM (one light sub-path per pixel)

# caustica configurations: label -> render_job keyword arguments
CONFIGS = {
    "sppm": dict(integrator="sppm"),
    "ppm": dict(integrator="ppm"),
    "pppm": dict(integrator="pppm"),
    "pppm r0=0.0066512 α=0.75": dict(integrator="pppm", radius=SVCM_R0, alpha=SVCM_ALPHA),
}


# ----------------------------------------------------------------------------------------------- helpers
def rel_mse(x: np.ndarray, r: np.ndarray) -> float:
    x = np.asarray(x, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    return float(np.mean((x - r) ** 2 / (r * r + 0.01)))


def read_hdr(path: str) -> np.ndarray:
    """Radiance RGBE reader for SmallVCM's writer: header, blank line, '-Y H +X W', then H*W flat RGBE
    quadruples (no run-length encoding), top scanline first. Returns float32 (H, W, 3)."""
    with open(path, "rb") as f:
        data = f.read()
    if not data.startswith(b"#?"):
        raise ValueError(f"{path}: not a Radiance file")
    pos = 0
    while True:                                   # header lines up to the blank line
        end = data.index(b"\n", pos)
        line, pos = data[pos:end], end + 1
        if line == b"":
            break
        if line.startswith(b"FORMAT=") and line != b"FORMAT=32-bit_rle_rgbe":
            raise ValueError(f"{path}: unsupported {line!r}")
    end = data.index(b"\n", pos)
    res, pos = data[pos:end].split(), end + 1
    if len(res) != 4 or res[0] != b"-Y" or res[2] != b"+X":
        raise ValueError(f"{path}: unsupported orientation {res!r}")
    h, w = int(res[1]), int(res[3])
    raw = np.frombuffer(data, dtype=np.uint8, offset=pos)
    if raw.size != h * w * 4:
        # run-length-encoded scanlines start with 2 2 (w >> 8) (w & 255); SmallVCM does not write them
        raise ValueError(f"{path}: {raw.size} bytes of pixels, expected {h * w * 4} (RLE not supported)")
    raw = raw.reshape(h, w, 4)
    e = raw[..., 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0)
    m = raw[..., :3].astype(np.float64)
    rgb = np.where(m > 0, m + 0.5, 0.0) * scale[..., None]   # mantissa 0 stays 0 (e.g. the sun's blue)
    return rgb.astype(np.float32)


from caustica._provenance import commit as _provenance_commit, machine  # noqa: E402
from caustica._provenance import cpu_busy_seconds, own_cpu_seconds  # noqa: E402,F401


def commit() -> str:
    return _provenance_commit(ROOT)


def loadavg() -> tuple[float, float, float]:
    try:
        return os.getloadavg()
    except OSError:
        return (float("nan"),) * 3


def log(msg: str) -> None:
    print(msg, flush=True)


def sha256(path: str) -> str:
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()[:16]


# ----------------------------------------------------------------------------------------------- SmallVCM
class SmallVCM:
    def __init__(self, binary: str):
        self.binary = os.path.abspath(binary)
        self.hash = sha256(self.binary)
        os.makedirs(OUT, exist_ok=True)

    def run(self, scene: int, algorithm: str, iterations: int, out: str) -> float:
        """Runs SmallVCM, returns the wall time of the whole process (s)."""
        cmd = [self.binary, "-s", str(scene), "-a", algorithm, "-i", str(iterations), "-o", out]
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if p.returncode != 0 or not os.path.exists(out):
            raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stdout}\n{p.stderr}")
        return wall

    def render(self, scene: int, algorithm: str, iterations: int) -> tuple[np.ndarray, float]:
        out = os.path.join(OUT, f"tmp_s{scene}_{algorithm}.hdr")
        wall = self.run(scene, algorithm, iterations, out)
        img = read_hdr(out)
        os.remove(out)
        return img, wall

    def per_iteration(self, scene: int, algorithm: str, lo: int = 4, hi: int = 12) -> tuple[float, float]:
        """(seconds per iteration, fixed seconds per run) from runs of lo and hi iterations."""
        _, w_lo = self.render(scene, algorithm, lo)
        _, w_hi = self.render(scene, algorithm, hi)
        slope = max((w_hi - w_lo) / (hi - lo), 1e-3)
        return slope, max(w_lo - lo * slope, 0.0)


def even(n: float, least: int = 2) -> int:
    return max(least, 2 * int(round(n / 2.0)))


def reference(sv: SmallVCM, scene: int, seconds: float, noise: bool, new: bool = False) -> dict:
    """SmallVCM vcm reference for a scene: the cached one with the most iterations, else (or with new=True)
    a new render of about `seconds` wall time (never fewer iterations than the best cached one)."""
    cached = []
    for meta_path in glob.glob(os.path.join(OUT, f"ref_s{scene}_vcm_i*.json")):
        with open(meta_path) as f:
            meta = json.load(f)
        if os.path.exists(meta["npy"]):
            cached.append(meta)
    cached.sort(key=lambda m: m["iterations"])
    best = cached[-1] if cached else None
    if best is None or new or (noise and "noise_relmse" not in best):
        slope, fixed = sv.per_iteration(scene, "vcm")
        n = max(even((seconds - fixed) / slope, least=8), best["iterations"] if best else 0)
        log(f"  scene {scene}: rendering SmallVCM vcm reference, {n} iterations "
            f"({slope:.2f} s/iteration now, ~{fixed + n * slope:.0f} s)")
        img, wall = sv.render(scene, "vcm", n)
        npy = os.path.join(OUT, f"ref_s{scene}_vcm_i{n}.npy")
        np.save(npy, img)
        best = {"scene": scene, "algorithm": "vcm", "iterations": n, "wall_s": wall, "npy": npy,
                "binary_sha256_16": sv.hash,
                "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                "commit": commit()}
        if noise:
            q = even(n / 4, least=2)
            quarter, wq = sv.render(scene, "vcm", q)
            best["noise_quarter_iterations"] = q
            best["noise_relmse"] = rel_mse(quarter, img) / 3.0
        with open(npy[:-4] + ".json", "w") as f:
            json.dump(best, f, indent=1)
    else:
        log(f"  scene {scene}: cached SmallVCM vcm reference, {best['iterations']} iterations")
    best["image"] = np.load(best["npy"])
    return best


# ----------------------------------------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--smallvcm", default="/tmp/smallvcm/smallvcm", help="SmallVCM binary")
    ap.add_argument("--scenes", default="0,1,2,3", help="SmallVCM scene ids (-s)")
    ap.add_argument("--budgets", default="5,20", help="wall-time budgets in seconds")
    ap.add_argument("--configs", default=",".join(CONFIGS), help="caustica configurations: " + ", ".join(CONFIGS))
    ap.add_argument("--ref-seconds", type=float, default=120.0, help="wall time of each new vcm reference")
    ap.add_argument("--new-ref", action="store_true", help="render new references even if cached ones exist")
    ap.add_argument("--no-ref-noise", action="store_true", help="skip the N/4 render estimating reference noise")
    ap.add_argument("--path-check-seconds", type=float, default=20.0,
                    help="caustica path render on scenes 1 and 3 checked against the reference (0: skip)")
    ap.add_argument("--equal-passes", type=int, default=32,
                    help="also compare relMSE at this many passes/iterations (0: skip)")
    ap.add_argument("--seed", type=int, default=1, help="caustica seed")
    ap.add_argument("--no-results", action="store_true", help="do not append to bench/RESULTS.md")
    ap.add_argument("--note", default="", help="text appended to the block in RESULTS.md")
    a = ap.parse_args(argv)

    import caustica

    scenes = [int(s) for s in a.scenes.split(",") if s.strip()]
    budgets = [float(b) for b in a.budgets.split(",") if b.strip()]
    configs = [c.strip() for c in a.configs.split(",") if c.strip()]
    for c in configs:
        if c not in CONFIGS:
            ap.error(f"unknown configuration {c!r}")
    if not os.path.exists(a.smallvcm):
        ap.error(f"{a.smallvcm} not found: build SmallVCM first (bench/smallvcm/README.md)")

    started = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    com = commit()
    mach = machine()
    load0 = loadavg()
    cmdline = ".venv/bin/python bench/bench_smallvcm.py" + ("" if argv is None and len(sys.argv) == 1
                                                            else " " + " ".join(sys.argv[1:] if argv is None else argv))
    log(f"{started}; {mach}; commit {com}; load average {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}")
    sv = SmallVCM(a.smallvcm)
    log(f"SmallVCM binary {sv.binary} (sha256 {sv.hash}...)")

    # 1. references
    log("references (SmallVCM vcm):")
    refs = {s: reference(sv, s, a.ref_seconds, not a.no_ref_noise, a.new_ref) for s in scenes}

    # 2. path check
    checks = {}
    if a.path_check_seconds > 0:
        for s in scenes:
            if s not in (1, 3):
                continue
            sc = caustica.load_scene(SCENES[s])
            r = caustica.render_job(sc, integrator="path", time=a.path_check_seconds, seed=a.seed)
            ref = refs[s]["image"]
            checks[s] = {"spp": int(r.stats.get("passes", 0)), "seconds": float(r.stats.get("seconds", 0)),
                         "relmse": rel_mse(r.image, ref), "mean": float(r.image.mean()),
                         "ref_mean": float(ref.mean())}
            log(f"  path check scene {s}: {checks[s]}")

    # 3. equal time
    rows = []
    busy0, own0, t0 = cpu_busy_seconds(), own_cpu_seconds(), time.perf_counter()
    for s in scenes:
        ref = refs[s]["image"]
        sc = caustica.load_scene(SCENES[s])
        caustica.render_job(sc, integrator="sppm", spp=1, photons=PHOTONS, seed=a.seed)   # warm-up
        slope, fixed = sv.per_iteration(s, "ppm")
        log(f"scene {s} ({SCENES[s]}): SmallVCM ppm {slope:.3f} s/iteration + {fixed:.3f} s fixed")
        for b in budgets:
            n = even((b - fixed) / slope)
            img, wall = sv.render(s, "ppm", n)
            e_sv = rel_mse(img, ref)
            log(f"  budget {b:g} s: SmallVCM ppm {n} iterations, {wall:.2f} s, relMSE {e_sv:.5f}, "
                f"mean {img.mean():.4f} (ref {ref.mean():.4f})")
            for c in configs:
                kw = dict(CONFIGS[c])
                tc = time.perf_counter()
                r = caustica.render_job(sc, time=wall, photons=PHOTONS, seed=a.seed, **kw)
                call = time.perf_counter() - tc
                e_c = rel_mse(r.image, ref)
                row = {"scene": s, "budget": b, "svcm_iterations": n, "svcm_wall": wall, "svcm_relmse": e_sv,
                       "svcm_mean": float(img.mean()), "config": c, "passes": int(r.stats["passes"]),
                       "seconds": float(r.stats["seconds"]), "call_s": call, "relmse": e_c,
                       "mean": float(r.image.mean()), "radius": float(r.stats.get("radius", float("nan"))),
                       "ratio": e_c / e_sv, "ref_mean": float(ref.mean())}
                nz = refs[s].get("noise_relmse")
                if nz is not None and e_sv > nz and e_c > nz:
                    row["ratio_denoised"] = (e_c - nz) / (e_sv - nz)
                rows.append(row)
                log(f"    caustica {c}: {row['passes']} passes, {row['seconds']:.2f} s, relMSE {e_c:.5f}, "
                    f"mean {row['mean']:.4f}, ratio {row['ratio']:.3f}")
    elapsed = time.perf_counter() - t0
    other = (cpu_busy_seconds() - busy0 - (own_cpu_seconds() - own0)) / elapsed

    # 4. equal work: the same number of passes (= SmallVCM iterations: 512 x 512 light paths and one camera
    #    path per pixel each), to separate per-pass error from speed
    passes = []
    if a.equal_passes > 0:
        n = even(a.equal_passes)
        for s in scenes:
            ref = refs[s]["image"]
            sc = caustica.load_scene(SCENES[s])
            img, wall = sv.render(s, "ppm", n)
            row = {"scene": s, "passes": n, "svcm_relmse": rel_mse(img, ref), "svcm_wall": wall}
            for label, kw in (("pppm r0=0.0066512 α=0.75", dict(radius=SVCM_R0, alpha=SVCM_ALPHA)),
                              ("pppm", {})):
                r = caustica.render_job(sc, integrator="pppm", spp=n, photons=PHOTONS, seed=a.seed, **kw)
                row[label] = {"relmse": rel_mse(r.image, ref), "seconds": float(r.stats["seconds"]),
                              "radius": float(r.stats.get("radius", float("nan")))}
            passes.append(row)
            log(f"  equal passes, scene {s}: {row}")
    load1 = loadavg()
    log(f"other work during the timed phase: {other:.2f} cores on average; load average after "
        f"{load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}")

    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, "last_run.json"), "w") as f:
        json.dump({"started": started, "commit": com, "machine": mach, "rows": rows, "checks": checks,
                   "equal_passes": passes,
                   "refs": {s: {k: v for k, v in m.items() if k != "image"} for s, m in refs.items()},
                   "other_cores": other, "load": [load0, load1]}, f, indent=1)

    block = format_block(started, mach, com, cmdline, load0, load1, other, sv, refs, checks, rows, passes,
                         a.note)
    print(block)
    if not a.no_results:
        with open(RESULTS, "a") as f:
            f.write(block)
        log(f"appended to {RESULTS}")
    return 0


def format_block(started, mach, com, cmdline, load0, load1, other, sv, refs, checks, rows, passes,
                 note) -> str:
    L = []
    L.append("")
    L.append("")
    L.append(f"## {started}, commit {com}: caustica photon mappers vs SmallVCM `ppm`, equal wall time")
    L.append("")
    L.append(f"Command: `{cmdline}`  ")
    L.append(f"Machine: {mach}. Load average {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f} before, "
             f"{load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f} after; other work during the timed phase "
             f"(/proc/stat less this benchmark's own CPU): {other:.2f} of {os.cpu_count()} cores on average.  ")
    L.append(f"SmallVCM: built outside the tree (bench/smallvcm/README.md), binary sha256 {sv.hash}…, "
             "`-a ppm -i N` (2 OpenMP threads, N even), r0 = 0.0066512, α = 0.75, merging at the first "
             "non-specular camera vertex, all light (direct included) from photons; wall time = its whole "
             "process (start, render, HDR write).  ")
    L.append("caustica: `render_job(scene, integrator, time=W, photons=262144, seed=1)`, all threads, W = "
             "SmallVCM's measured wall time for the budget (scene loaded beforehand); radius automatic and "
             "α = 0.7 unless the row says otherwise; direct light by NEE at the visible point, photons for "
             "indirect light.  ")
    ref_desc = []
    for s, m in refs.items():
        d = f"scene {s}: {m['iterations']} iterations ({m['wall_s']:.0f} s)"
        if "noise_relmse" in m:
            d += f", noise ≈ {m['noise_relmse']:.2e}"
        ref_desc.append(d)
    L.append("Reference: SmallVCM `vcm` (vertex connection and merging, consistent, all light paths), "
             + "; ".join(ref_desc) + ". Reference noise = relMSE(N/4-iteration render, reference) / 3 "
             "(SmallVCM's fixed seeds make the N/4 render nearly a subset of the N one); it is part of "
             "every relMSE below; the last column subtracts it from both errors.  ")
    if checks:
        cs = "; ".join(f"scene {s}: {c['spp']} spp in {c['seconds']:.0f} s, relMSE {c['relmse']:.5f}, "
                       f"mean {c['mean']:.4f} vs {c['ref_mean']:.4f}" for s, c in checks.items())
        L.append(f"Scene check, caustica `path` against the SmallVCM reference: {cs}.  ")
    L.append("")
    L.append("| scene | budget (s) | SmallVCM ppm iterations | SmallVCM wall (s) | SmallVCM relMSE | caustica "
             "config | caustica passes | caustica render (s) | caustica relMSE | ratio caustica / SmallVCM | "
             "ratio, reference noise subtracted |")
    L.append("|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|")
    for r in rows:
        L.append(f"| {r['scene']} {SCENES[r['scene']]} | {r['budget']:g} | {r['svcm_iterations']} | "
                 f"{r['svcm_wall']:.2f} | {r['svcm_relmse']:.5f} | {r['config']} | {r['passes']} | "
                 f"{r['seconds']:.2f} | {r['relmse']:.5f} | **{r['ratio']:.3f}** | "
                 + (f"{r['ratio_denoised']:.3f} |" if "ratio_denoised" in r else "— |"))
    L.append("")
    means = {}
    for r in rows:
        means.setdefault((r["scene"], r["budget"]), (r["ref_mean"], r["svcm_mean"], []))[2].append(
            f"{r['config']} {r['mean']:.4f}")
    L.append("Image means (all channels): " + "; ".join(
        f"scene {s} {b:g} s: reference {rm:.4f}, SmallVCM {sm:.4f}, " + ", ".join(cm)
        for (s, b), (rm, sm, cm) in means.items()) + ".")
    if passes:
        L.append("")
        L.append(f"Equal work instead of equal time: relMSE after the same number of passes (a SmallVCM `ppm` "
                 f"iteration and a caustica pass both trace 512 × 512 photon paths and one camera path per pixel); "
                 f"ratio to SmallVCM in brackets; wall seconds after the slash.")
        L.append("")
        L.append("| scene | passes | SmallVCM ppm | caustica pppm r0=0.0066512 α=0.75 | caustica pppm (automatic r0) |")
        L.append("|---|---:|---:|---:|---:|")
        for p in passes:
            m, c = p["pppm r0=0.0066512 α=0.75"], p["pppm"]
            L.append(f"| {p['scene']} {SCENES[p['scene']]} | {p['passes']} | {p['svcm_relmse']:.5f} / "
                     f"{p['svcm_wall']:.1f} s | {m['relmse']:.5f} ({m['relmse'] / p['svcm_relmse']:.2f}) / "
                     f"{m['seconds']:.1f} s | {c['relmse']:.5f} ({c['relmse'] / p['svcm_relmse']:.2f}) / "
                     f"{c['seconds']:.1f} s, r0 {c['radius']:.4f} |")
    if note:
        L.append("")
        L.append(note)
    L.append("")
    return "\n".join(L)


if __name__ == "__main__":
    sys.exit(main())
