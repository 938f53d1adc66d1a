#!/usr/bin/env python3
"""Cornell box benchmark: caustica against Mitsuba 3 on the same scene, at equal error.

Scene: caustica's built-in `cornell`, which is Mitsuba 3's `mitsuba.cornell_box()` (256x256; see
shared/scenes/cornell-box.md), with a one-pixel box filter, path tracing with max_depth 8 (the camera
segment counts as depth 1, as in Mitsuba) and Russian roulette from depth 5 (Mitsuba's default rr_depth).

Getting Mitsuba (this script installs nothing itself):
    bash bench/install-mitsuba.sh
which, idempotently,
    .venv/bin/pip install mitsuba==3.9.1        # the version these figures were taken with (pulls drjit 1.5.0)
    apt-get install -y libllvm19                # Debian bookworm has it in main; Dr.Jit's LLVM backend loads it
and prints the library's path, e.g. /usr/lib/x86_64-linux-gnu/libLLVM-19.so, to pass as DRJIT_LIBLLVM_PATH.
This script looks for libLLVM-19 itself when DRJIT_LIBLLVM_PATH is unset. Without LLVM, Mitsuba runs in its
`scalar_rgb` variant (about 3x slower than `llvm_ad_rgb`), and the output says so. Without Mitsuba, only
caustica is measured.

What it does:
  1. Reference: caustica at --ref-spp (default 4096, sampler independent), cached in bench/out/ keyed by the
     parameters. Optionally a second reference from Mitsuba at --mitsuba-ref-spp (default: same), also cached.
     Both means are printed next to the known 0.14709 (Mitsuba 3.9.1, 16384 spp).
  2. relMSE = mean over pixels and channels of (x - r)^2 / (r^2 + 0.01).
  3. caustica at each spp of --spp, both samplers (sobol, independent), and Mitsuba at the same spp, all in
     one process and interleaved: for each repeat and spp every configuration renders in turn (rotating
     order), so that load from other work on the machine hits them alike. Warm-up first: one caustica render
     per sampler; one Mitsuba render per spp (its first render at a given spp JIT-compiles the kernel).
     Repeats use seeds 1..--repeats. Recorded: wall time of the render call (scene loaded beforehand; best of
     the repeats, as the machine may be shared; medians are printed too), samples/s (camera paths per
     second), rays/s ((rays + shadow_rays) / stats seconds; caustica only), relMSE (mean over repeats).
  4. Mitsuba's image orientation is checked against the reference (no flip is expected: red wall on the left).
  5. Time to equal relMSE, caustica / Mitsuba, at Mitsuba's relMSE at 64 spp: the spp caustica needs for that
     relMSE is interpolated log-log between its measured spp (relMSE is deterministic for given seeds; time is
     not), and turned into time with each renderer's best throughput (samples/s over renders of >= 16 spp);
     Mitsuba's time is 64 spp at its best throughput. Also shown: the same from measured times directly
     (log-log interpolation and least-squares fit of log relMSE against log time), which load from other
     work distorts more. Also: how much CPU other work took during the timed phase (/proc/stat less this
     benchmark's own CPU time).
  6. Peak resident memory (ru_maxrss): each configuration alone in its own process (load, render each spp
     once), so that one renderer's memory does not pollute the other's.
  7. Appends a block of rows to bench/RESULTS.md (unless --no-append).

Usage:
    .venv/bin/python bench/bench_cornell.py                       # full run (several minutes on 2 cores)
    .venv/bin/python bench/bench_cornell.py --ref-spp 1024 --repeats 2
    .venv/bin/python bench/bench_cornell.py --no-mitsuba --spp 16 64
"""
from __future__ import annotations

import argparse
import datetime as _dt
import glob
import json
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
OUT_DIR = os.path.join(HERE, "out")
RESULTS = os.path.join(HERE, "RESULTS.md")

SCENE = "cornell"
MAX_DEPTH = 8
RR_DEPTH = 5
KNOWN_MEAN = 0.14709          # Mitsuba 3.9.1 llvm_ad_rgb, 16384 spp, box filter (shared/scenes/cornell-box.md)
SAMPLERS = ("sobol", "independent")
REF_SEED = 1_000_003          # the references' seeds differ from the measurements' (1, 2, ...)
MI_REF_SEED = 2_000_000
PIXELS = 256 * 256


# ----------------------------------------------------------------------------------------------- helpers
def rel_mse(x: np.ndarray, r: np.ndarray) -> float:
    x = np.asarray(x, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    return float(np.mean((x - r) ** 2 / (r * r + 0.01)))


def peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0   # KiB on Linux


def current_rss_mib() -> float:
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:
        return float("nan")


def find_libllvm() -> str | None:
    pats = ["/usr/lib/x86_64-linux-gnu/libLLVM-19.so*", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19*",
            "/usr/lib/llvm-19/lib/libLLVM*.so*", "/usr/lib/*/libLLVM-1[6-9].so*", "/usr/lib/*/libLLVM.so.1[6-9]*"]
    for p in pats:
        hits = sorted(glob.glob(p))
        if hits:
            return hits[0]
    return None


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


# ----------------------------------------------------------------------------------------------- workers
# Each worker runs in its own process (python bench_cornell.py --worker NAME --job JSON --result PATH).

def _orient(img: np.ndarray, ref: np.ndarray | None):
    """Returns (name, function) of the flip that brings img closest to ref (Mitsuba's image should need none:
    its camera matrix flips x so that the red wall is on the left, as in caustica)."""
    cands = {"none": lambda a: a, "fliplr": lambda a: a[:, ::-1], "flipud": lambda a: a[::-1],
             "flip both": lambda a: a[::-1, ::-1]}
    if ref is None:
        return "none", cands["none"]
    errs = {k: rel_mse(f(img), ref) for k, f in cands.items()}
    best = min(errs, key=errs.get)
    return best, cands[best]


def worker_caustica_ref(job: dict) -> dict:
    import caustica
    s = caustica.load_scene(SCENE, filter="box")
    t = time.perf_counter()
    r = caustica.render_job(s, spp=job["spp"], seed=job["seed"], max_depth=MAX_DEPTH, rr_depth=RR_DEPTH,
                            sampler=job["sampler"], threads=job["threads"])
    t = time.perf_counter() - t
    np.save(job["path"], r.image.astype(np.float32))
    return {"seconds": t, "mean": float(r.image.mean()), "stats": r.stats}


def _mitsuba_setup(job: dict):
    """Imports Mitsuba with the best variant available; returns (mi, variant, note)."""
    import mitsuba as mi
    note = ""
    variant = job.get("variant") or "llvm_ad_rgb"
    try:
        mi.set_variant(variant)
        if variant.startswith("llvm"):
            import drjit as dr
            x = mi.Float(1.0) + 1.0                          # makes Dr.Jit load LLVM and compile a kernel
            dr.eval(x)
            if float(x[0]) != 2.0:
                raise RuntimeError("LLVM backend self-test failed")
    except Exception as e:                                  # no LLVM: fall back to the scalar variant
        note = f"{variant} unavailable ({type(e).__name__}: {str(e).splitlines()[0][:300]}); fell back to scalar_rgb"
        variant = "scalar_rgb"
        mi.set_variant(variant)
    if job.get("threads"):
        import drjit as dr
        dr.set_thread_count(job["threads"])
    return mi, variant, note


def _mitsuba_scene(mi):
    d = mi.cornell_box()
    d["sensor"]["film"]["rfilter"] = {"type": "box"}
    d["integrator"] = {"type": "path", "max_depth": MAX_DEPTH, "rr_depth": RR_DEPTH}
    return mi.load_dict(d)


def worker_mitsuba_ref(job: dict) -> dict:
    mi, variant, note = _mitsuba_setup(job)
    scene = _mitsuba_scene(mi)
    chunk = job["chunk"]
    n = max(1, job["spp"] // chunk)
    acc = None
    t = time.perf_counter()
    for i in range(n):                                       # box filter: the mean of equal-spp images is exact
        img = np.array(mi.render(scene, spp=chunk, seed=job["seed"] + i), dtype=np.float64)
        acc = img if acc is None else acc + img
    t = time.perf_counter() - t
    img = (acc / n).astype(np.float32)
    cref = np.load(job["caustica_ref"]) if job.get("caustica_ref") else None
    orient, f = _orient(img, cref)
    img = np.ascontiguousarray(f(img))
    np.save(job["path"], img)
    return {"seconds": t, "spp": n * chunk, "mean": float(img.mean()), "variant": variant, "note": note,
            "orientation": orient, "mitsuba": mi.__version__}


def _renderers(job: dict, ref: np.ndarray) -> dict:
    """Loads the scene in each configuration of job["configs"]; returns {name: render(spp, seed) -> (image,
    seconds, stats)} plus, for Mitsuba, its setup facts under "_mitsuba"."""
    out = {}
    for cfg in job["configs"]:
        if cfg["kind"] == "caustica":
            import caustica
            s = caustica.load_scene(SCENE, filter="box")
            kw = dict(max_depth=MAX_DEPTH, rr_depth=RR_DEPTH, sampler=cfg["sampler"], threads=job["threads"])

            def render(spp, seed, s=s, kw=kw):
                t = time.perf_counter()
                r = caustica.render_job(s, spp=spp, seed=seed, **kw)
                return r.image, time.perf_counter() - t, r.stats
            out[cfg["name"]] = render
        else:
            mi, variant, note = _mitsuba_setup(job)
            scene = _mitsuba_scene(mi)
            flip = {"f": None}

            def render(spp, seed, mi=mi, scene=scene, flip=flip):
                t = time.perf_counter()
                img = np.array(mi.render(scene, spp=spp, seed=seed))   # np.array forces evaluation
                t = time.perf_counter() - t
                if flip["f"] is None:                                 # the first image sets the orientation
                    flip["orient"], flip["f"] = _orient(img, ref)
                return flip["f"](img), t, None
            out[cfg["name"]] = render
            out["_mitsuba"] = {"name": cfg["name"], "variant": variant, "note": note, "version": mi.__version__,
                               "flip": flip}
    return out


def worker_timing(job: dict) -> dict:
    """Times all configurations in one process, interleaved (each (repeat, spp) renders every configuration in
    turn, in a rotating order), so that load from other work on the machine hits them alike."""
    ref = np.load(job["ref"])
    mref = np.load(job["mitsuba_ref"]) if job.get("mitsuba_ref") else None
    rend = _renderers(job, ref)
    names = [c["name"] for c in job["configs"]]
    mi_info = rend.pop("_mitsuba", None)
    warm = {}
    for name in names:                       # warm-up: caches, thread pools; Mitsuba JIT-compiles per spp
        for spp in (job["spp"] if mi_info and name == mi_info["name"] else job["spp"][:1]):
            warm[(name, spp)] = rend[name](spp, 999)[1]
    data = {n: {spp: {"times": [], "relmses": [], "relmses_mref": [], "means": [], "rays": [], "samples": []}
                for spp in job["spp"]} for n in names}
    i = 0
    for k in range(job["repeats"]):
        for spp in job["spp"]:
            order = names[i % len(names):] + names[: i % len(names)]
            i += 1
            for name in order:
                img, t, st = rend[name](spp, 1 + k)
                d = data[name][spp]
                d["times"].append(t)
                d["relmses"].append(rel_mse(img, ref))
                if mref is not None:
                    d["relmses_mref"].append(rel_mse(img, mref))
                d["means"].append(float(img.mean()))
                d["samples"].append(spp * img.shape[0] * img.shape[1] / t)
                if st is not None:
                    d["rays"].append((st["rays"] + st["shadow_rays"]) / max(st["seconds"], 1e-9))
    res = {}
    for name in names:
        rows = []
        for spp in job["spp"]:
            d = data[name][spp]
            rows.append({"spp": spp, "time": float(np.min(d["times"])), "median_time": float(np.median(d["times"])),
                         "times": d["times"], "warmup_time": warm.get((name, spp)),
                         "relmse": float(np.mean(d["relmses"])), "relmses": d["relmses"],
                         "relmse_vs_mitsuba_ref": float(np.mean(d["relmses_mref"])) if d["relmses_mref"] else None,
                         "samples_per_s": float(np.max(d["samples"])),
                         "rays_per_s": float(np.max(d["rays"])) if d["rays"] else None,
                         "mean": float(np.mean(d["means"]))})
        res[name] = {"rows": rows}
        if mi_info and name == mi_info["name"]:
            f = mi_info["flip"]
            img = f["f"](np.array(rend[name](16, 7)[0]))
            h = img.shape[1] // 2
            res[name].update(variant=mi_info["variant"], note=mi_info["note"], version=mi_info["version"],
                             orientation=f["orient"],
                             red_wall_left=bool(img[:, :h, 0].mean() > img[:, h:, 0].mean()))
    return res


def worker_memory(job: dict) -> dict:
    """Peak resident memory of one configuration alone: load the scene, render once at each spp."""
    ref = np.load(job["ref"])
    rend = _renderers(job, ref)
    rend.pop("_mitsuba", None)
    (render,) = rend.values()
    rss_loaded = current_rss_mib()
    for spp in job["spp"]:
        render(spp, 1)
    return {"rss_loaded_mib": rss_loaded, "peak_rss_mib": peak_rss_mib()}


WORKERS = {"caustica-ref": worker_caustica_ref, "mitsuba-ref": worker_mitsuba_ref, "timing": worker_timing,
           "memory": worker_memory}


def run_worker(name: str, job: dict, env: dict | None = None) -> dict:
    with tempfile.NamedTemporaryFile(suffix=".json", dir=OUT_DIR, delete=False) as f:
        path = f.name
    try:
        cmd = [sys.executable, os.path.abspath(__file__), "--worker", name, "--job", json.dumps(job),
               "--result", path]
        p = subprocess.run(cmd, env=env)
        if p.returncode != 0:
            raise RuntimeError(f"worker {name} failed with exit status {p.returncode}")
        with open(path) as f:
            return json.load(f)
    finally:
        try:
            os.unlink(path)
        except OSError:
            pass


# ----------------------------------------------------------------------------------------------- analysis
def interp_time(rows: list[dict], target: float) -> float | None:
    """Time at which relMSE reaches target, interpolating log-log between measured (time, relMSE) points
    (None when the target lies outside the measured range). Sensitive to timing noise."""
    pts = sorted((r["time"], r["relmse"]) for r in rows)
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if min(e0, e1) <= target <= max(e0, e1) and e0 != e1:
            a = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + a * (math.log(t1) - math.log(t0)))
    return None


def fit(rows: list[dict], x: str = "time") -> tuple[float, float]:
    """Least-squares fit log(relMSE) = a + b log(x) over the measured points; returns (a, b)."""
    b, a = np.polyfit(np.log([r[x] for r in rows]), np.log([r["relmse"] for r in rows]), 1)
    return float(a), float(b)


def fit_time(rows: list[dict], target: float) -> float:
    a, b = fit(rows)
    return math.exp((math.log(target) - a) / b)


def spp_for(rows: list[dict], target: float) -> tuple[float, str]:
    """spp at which relMSE reaches target: log-log interpolation between the measured spp (relMSE is
    deterministic for given seeds, unlike time), or the log-log least-squares fit outside the measured range."""
    pts = sorted((r["spp"], r["relmse"]) for r in rows)
    for (s0, e0), (s1, e1) in zip(pts, pts[1:]):
        if min(e0, e1) <= target <= max(e0, e1) and e0 != e1:
            a = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(s0) + a * (math.log(s1) - math.log(s0))), "interpolated"
    a, b = fit(rows, "spp")
    return math.exp((math.log(target) - a) / b), "extrapolated"


def throughput(rows: list[dict]) -> float:
    """Camera paths per second: the best over the renders at 16 spp or more (where fixed costs are
    amortised); the best rather than a mean because load from other work only ever slows a render down."""
    big = [r for r in rows if r["spp"] >= 16] or rows
    return max(r["samples_per_s"] for r in big)


def at_spp(rows: list[dict], spp: int) -> dict:
    return min(rows, key=lambda r: (abs(r["spp"] - spp), -r["spp"]))


# ----------------------------------------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spp", type=int, nargs="+", default=[4, 8, 16, 32, 64, 128], help="spp to measure")
    ap.add_argument("--repeats", type=int, default=3, help="timed renders per spp (seeds 1..N)")
    ap.add_argument("--ref-spp", type=int, default=4096, help="spp of caustica's reference")
    ap.add_argument("--ref-sampler", default="independent", choices=SAMPLERS)
    ap.add_argument("--mitsuba-ref-spp", type=int, default=None,
                    help="spp of Mitsuba's reference (default: --ref-spp; 0: none)")
    ap.add_argument("--samplers", nargs="+", default=list(SAMPLERS), choices=SAMPLERS)
    ap.add_argument("--threads", type=int, default=0, help="0: all cores (both renderers)")
    ap.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant (falls back to scalar_rgb)")
    ap.add_argument("--no-mitsuba", action="store_true")
    ap.add_argument("--fresh-ref", action="store_true", help="re-render the cached references")
    ap.add_argument("--no-append", action="store_true", help="do not append to bench/RESULTS.md")
    ap.add_argument("--note", default="", help="free text for the RESULTS.md block")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--job", help=argparse.SUPPRESS)
    ap.add_argument("--result", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)

    if a.worker:
        res = WORKERS[a.worker](json.loads(a.job))
        with open(a.result, "w") as f:
            json.dump(res, f)
        return 0

    os.makedirs(OUT_DIR, exist_ok=True)
    spps = sorted(set(a.spp))
    mi_ref_spp = a.ref_spp if a.mitsuba_ref_spp is None else a.mitsuba_ref_spp
    started = _dt.datetime.now(_dt.timezone.utc)
    com = commit()                     # at the start: the tree may change under a long run
    load0 = loadavg()
    cmd_line = " ".join([".venv/bin/python", "bench/bench_cornell.py"] + (sys.argv[1:] if argv is None else argv))
    log(f"machine: {machine()}; commit {com}; load average {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}")

    # --- caustica reference (cached)
    ref_path = os.path.join(OUT_DIR, f"ref_caustica_{SCENE}_box_d{MAX_DEPTH}_rr{RR_DEPTH}_{a.ref_sampler}"
                                     f"_{a.ref_spp}spp_seed{REF_SEED}.npy")
    meta_path = ref_path[:-4] + ".json"
    if a.fresh_ref or not os.path.exists(ref_path):
        log(f"rendering caustica's reference: {a.ref_spp} spp, sampler {a.ref_sampler} ...")
        r = run_worker("caustica-ref", {"spp": a.ref_spp, "seed": REF_SEED, "sampler": a.ref_sampler,
                                         "threads": a.threads, "path": ref_path})
        with open(meta_path, "w") as f:
            json.dump({"commit": com, "date": started.isoformat(), "seconds": r["seconds"]}, f)
        log(f"  done in {r['seconds']:.1f} s")
    ref = np.load(ref_path)
    ref_meta = json.load(open(meta_path)) if os.path.exists(meta_path) else {}
    if ref_meta.get("commit") and ref_meta["commit"] != com:
        log(f"  note: cached reference rendered at commit {ref_meta['commit']} (now {com}); "
            f"--fresh-ref re-renders it")
    log(f"caustica reference ({a.ref_spp} spp): mean {ref.mean():.5f} (known {KNOWN_MEAN}; "
        f"{100 * (ref.mean() / KNOWN_MEAN - 1):+.2f}%)")

    # --- Mitsuba environment
    mi_env = dict(os.environ)
    have_mitsuba = False
    if not a.no_mitsuba:
        try:
            import importlib.util
            have_mitsuba = importlib.util.find_spec("mitsuba") is not None
        except Exception:
            have_mitsuba = False
        if not have_mitsuba:
            log("Mitsuba is not installed (bash bench/install-mitsuba.sh); measuring caustica only")
        elif a.variant.startswith("llvm") and not mi_env.get("DRJIT_LIBLLVM_PATH"):
            llvm = find_libllvm()
            if llvm:
                mi_env["DRJIT_LIBLLVM_PATH"] = llvm
    if have_mitsuba:
        log(f"DRJIT_LIBLLVM_PATH={mi_env.get('DRJIT_LIBLLVM_PATH', '(unset)')}")

    # --- Mitsuba reference (cached)
    mref_path, mref_info, ref_cross = None, None, None
    if have_mitsuba and mi_ref_spp > 0:
        chunk = min(max(spps), mi_ref_spp)                  # the kernel of the largest measured spp
        mi_ref_spp = max(1, round(mi_ref_spp / chunk)) * chunk
        mref_path = os.path.join(OUT_DIR, f"ref_mitsuba_{SCENE}_box_d{MAX_DEPTH}_rr{RR_DEPTH}_{a.variant}"
                                          f"_{mi_ref_spp}spp_chunk{chunk}_seed{MI_REF_SEED}.npy")
        minfo_path = mref_path[:-4] + ".json"
        if a.fresh_ref or not os.path.exists(mref_path):
            log(f"rendering Mitsuba's reference: {mi_ref_spp} spp in renders of {chunk} spp ...")
            mref_info = run_worker("mitsuba-ref", {"spp": mi_ref_spp, "chunk": chunk, "seed": MI_REF_SEED,
                                                    "variant": a.variant, "threads": a.threads,
                                                    "path": mref_path, "caustica_ref": ref_path}, env=mi_env)
            with open(minfo_path, "w") as f:
                json.dump(mref_info, f)
            log(f"  done in {mref_info['seconds']:.1f} s ({mref_info['variant']})")
        mref_info = json.load(open(minfo_path)) if os.path.exists(minfo_path) else {}
        mref = np.load(mref_path)
        log(f"Mitsuba reference ({mref_info.get('spp', mi_ref_spp)} spp, {mref_info.get('variant', '?')}, "
            f"orientation fix: {mref_info.get('orientation', '?')}): mean {mref.mean():.5f} (known {KNOWN_MEAN}; "
            f"{100 * (mref.mean() / KNOWN_MEAN - 1):+.2f}%)")
        ref_cross = rel_mse(ref, mref)
        log(f"relMSE between the two references: {ref_cross:.3g} (both noisy; 0 would mean identical images; "
            f"noise alone gives about 2 x (Mitsuba's 64-spp relMSE, ~0.0044) x 64 / ref spp)")

    # --- measurements: timing and error, all configurations interleaved in one process
    configs = [{"name": f"caustica {smp}", "kind": "caustica", "sampler": smp} for smp in a.samplers]
    if have_mitsuba:
        configs.append({"name": "Mitsuba", "kind": "mitsuba"})
    common = {"spp": spps, "repeats": a.repeats, "variant": a.variant, "threads": a.threads, "ref": ref_path,
              "mitsuba_ref": mref_path}
    log(f"measuring {', '.join(c['name'] for c in configs)} interleaved: spp {spps}, {a.repeats} repeats ...")
    busy0, own0, wall0 = cpu_busy_seconds(), own_cpu_seconds(), time.perf_counter()
    results = run_worker("timing", dict(common, configs=configs), env=mi_env)
    wall = time.perf_counter() - wall0
    foreign = max(0.0, (cpu_busy_seconds() - busy0) - (own_cpu_seconds() - own0)) / wall
    log(f"  {wall:.0f} s; other work on the machine used {foreign:.2f} of {os.cpu_count()} cores on average "
        f"meanwhile")
    mi_key = None
    if have_mitsuba:
        res = results.pop("Mitsuba")
        mi_key = f"Mitsuba {res['version']} {res['variant']}"
        results[mi_key] = res
        if res["note"]:
            log(f"  NOTE: {res['note']}")
        log(f"  Mitsuba image orientation fix: {res['orientation']}; red wall on the left: {res['red_wall_left']}")
    # --- memory: each configuration alone in its own process
    log("measuring peak memory, each configuration in its own process ...")
    for cfg, name in zip(configs, results):
        results[name].update(run_worker("memory", dict(common, configs=[cfg]), env=mi_env))
    load1 = loadavg()

    # --- report
    log("")
    log(f"relMSE against caustica's {a.ref_spp}-spp reference (mean over {a.repeats} seeds); "
        f"time = best (median) of {a.repeats} wall times of the render call")
    hdr = (f"{'renderer':<32} {'spp':>5} {'time s':>8} {'(median)':>8} {'Msamples/s':>10} {'Mrays/s':>8} "
           f"{'relMSE':>10} {'mean':>8}")
    log(hdr)
    for name, res in results.items():
        for r in res["rows"]:
            rays = f"{r['rays_per_s'] / 1e6:8.2f}" if r["rays_per_s"] else f"{'-':>8}"
            log(f"{name:<32} {r['spp']:>5} {r['time']:>8.3f} {'(%.3f)' % r['median_time']:>8} "
                f"{r['samples_per_s'] / 1e6:>10.3f} {rays} "
                f"{r['relmse']:>10.4g} {r['mean']:>8.5f}")
    if mi_key and results[mi_key]["rows"][0].get("relmse_vs_mitsuba_ref") is not None:
        r64 = at_spp(results[mi_key]["rows"], 64)
        log(f"Mitsuba at {r64['spp']} spp against Mitsuba's own reference: relMSE {r64['relmse_vs_mitsuba_ref']:.4g} "
            f"(cornell-box.md: 0.0044 against 16384 spp)")
    ref_noise = None
    if ref is not None:
        # The reference's own noise adds about (ref_spp_equiv)^-1 scaled error; report it as a fraction.
        r64c = at_spp(next(iter(results.values()))["rows"], 64)
        ref_noise = r64c["spp"] / a.ref_spp
        log(f"(the reference's own noise inflates relMSE by roughly spp/ref_spp: {100 * ref_noise:.1f}% at "
            f"{r64c['spp']} spp, if reference and measurement have similar per-sample variance)")

    ratios = {}
    if mi_key:
        mrows = results[mi_key]["rows"]
        m64 = at_spp(mrows, 64)
        target = m64["relmse"]
        thr_m = throughput(mrows)
        t_m = m64["spp"] * PIXELS / thr_m
        am, bm = fit(mrows)
        log("")
        log(f"Mitsuba at {m64['spp']} spp: relMSE {target:.4g}; best throughput {thr_m / 1e6:.3f} M samples/s, "
            f"so {t_m:.3f} s (measured best {m64['time']:.3f} s; fit relMSE ~ time^{bm:.2f})")
        for name, res in results.items():
            if name == mi_key:
                continue
            rows = res["rows"]
            spp_c, how = spp_for(rows, target)
            thr_c = throughput(rows)
            t_c = spp_c * PIXELS / thr_c
            ti = interp_time(rows, target)
            tf = fit_time(rows, target)
            ac, bc = fit(rows)
            ratios[name] = {"ratio": t_c / t_m, "spp": spp_c, "how": how, "throughput": thr_c,
                            "ratio_time_interp": ti / m64["time"] if ti else None,
                            "ratio_time_fit": tf / m64["time"]}
            log(f"time to equal relMSE, {name} / Mitsuba: {t_c / t_m:.2f} = ({spp_c:.1f} spp ({how}) / "
                f"{thr_c / 1e6:.3f} M samples/s = {t_c:.3f} s) / {t_m:.3f} s")
            log(f"    from measured times instead: log-log interpolation "
                + (f"{ti / m64['time']:.2f}" if ti else "n/a (out of range)")
                + f", log-log fit {tf / m64['time']:.2f} ({name}: relMSE ~ time^{bc:.2f})")
    log("")
    for name, res in results.items():
        log(f"peak RSS {name}: {res['peak_rss_mib']:.0f} MiB "
            f"(after loading the scene: {res['rss_loaded_mib']:.0f} MiB)")
    log(f"load average at start {load0[0]:.2f}, at end {load1[0]:.2f} (1 min); {os.cpu_count()} cores")

    with open(os.path.join(OUT_DIR, "last_run.json"), "w") as f:
        json.dump({"date": started.isoformat(), "command": cmd_line, "machine": machine(), "commit": com,
                   "commit_at_end": commit(), "load": [load0, load1], "foreign_cores": foreign,
                   "results": results, "ratios": ratios},
                  f, indent=1)

    if not a.no_append:
        append_results(a, started, com, cmd_line, results, ratios, mi_key, ref, mref_info, mi_ref_spp, foreign,
                       spps, ref_meta.get("commit", "?"), ref_cross)
        log(f"appended to {os.path.relpath(RESULTS, ROOT)}")
    return 0


RESULTS_HEADER = """# caustica benchmark results: Cornell box (Mitsuba 3's `cornell_box()`)

Written by `bench/bench_cornell.py` (one block per run, appended). The scene is caustica's built-in `cornell`,
the same as Mitsuba 3's `mitsuba.cornell_box()`: 256 x 256, one-pixel box filter, path tracing with
max_depth 8 (camera segment = depth 1), Russian roulette from depth 5. Timings: all renderers/configs in one
process, interleaved render by render; peak memory: each renderer/config alone in its own process.

Columns:
- **date**: UTC date and time the run started.
- **machine**: CPU model name from /proc/cpuinfo and the number of cores.
- **commit**: `git rev-parse --short HEAD` at the start of the run, with `-dirty` when tracked files had
  uncommitted changes.
- **renderer**: caustica with its sampler (sobol is the default), or Mitsuba with its version and variant
  (`llvm_ad_rgb` needs libLLVM, see bench/install-mitsuba.sh; `scalar_rgb` is the fallback).
- **samples/s**: camera paths per second at 64 spp (256·256·64 / best wall time of the render call).
- **best samples/s**: the best over all renders at 16 spp or more: the throughput the ratio uses.
- **rays/s**: (camera + bounce rays + shadow rays) / render seconds at 64 spp, from caustica's stats (best of
  the repeats); Mitsuba does not report ray counts.
- **time 64 spp**: best of the repeats' wall times of the render call at 64 spp (scene loaded beforehand, after
  a warm-up render; for Mitsuba after one warm-up render at the same spp, which JIT-compiles its kernel). Best
  rather than median because load from other work only ever slows a render down; the medians are in the
  script's printout and in bench/out/last_run.json.
- **relMSE 64 spp**: mean over pixels and channels of (x − r)² / (r² + 0.01) against caustica's
  high-spp reference (spp given in the block's settings), averaged over the repeats' seeds.
- **peak RSS**: peak resident memory (ru_maxrss) of a process that ran only this renderer/config (Python,
  NumPy and the reference image included: about 40 MiB of it is not the renderer's).
- **time to equal relMSE / Mitsuba**: the time caustica needs to reach Mitsuba's 64-spp relMSE divided by
  Mitsuba's time for its 64 spp. caustica's spp for that relMSE is interpolated log-log between its measured
  spp (relMSE is deterministic for given seeds); times are spp / best samples/s for both renderers. In
  brackets: the same from measured times directly (least-squares fit of log relMSE against log time), which
  load from other work distorts more. Below 1 means caustica is faster at equal error.

Each block gives the command line and how much CPU other work on the machine took during the timed phase
(from /proc/stat, less this benchmark's own CPU time): figures taken while it was well above 0 are noisy.
"""


def append_results(a, started, com, cmd_line, results, ratios, mi_key, ref, mref_info, mi_ref_spp, foreign,
                   spps, ref_commit, ref_cross):
    new = not os.path.exists(RESULTS)
    date = started.strftime("%Y-%m-%d %H:%M UTC")
    mach = machine()
    com_end = commit()
    lines = []
    if new:
        lines.append(RESULTS_HEADER)
    spreads = [max(r["times"]) / min(r["times"]) for res in results.values() for r in res["rows"]]
    lines.append(f"\n## {date}, commit {com}\n")
    lines.append(f"Command: `{cmd_line}`  ")
    if com_end != com:
        lines.append(f"The working tree changed during the run (commit at the end: {com_end}); the figures are "
                     f"labelled with the commit at the start.  ")
    lines.append(f"Settings: reference caustica {a.ref_spp} spp ({a.ref_sampler}, rendered at commit {ref_commit}), "
                 f"mean {ref.mean():.5f} (known {KNOWN_MEAN})"
                 + (f"; Mitsuba reference {mref_info.get('spp', mi_ref_spp)} spp, "
                    f"mean {mref_info.get('mean', float('nan')):.5f}, relMSE between the two references "
                    f"{ref_cross:.3g}" if mref_info else "")
                 + f"; spp {', '.join(map(str, spps))}; {a.repeats} repeats; threads {a.threads or 'all'}.  ")
    lines.append(f"Other work on the machine during the timed phase: {foreign:.2f} of {os.cpu_count()} cores on "
                 f"average; slowest/fastest of the repeats: median {np.median(spreads):.2f}, worst "
                 f"{max(spreads):.2f}"
                 + (" — **the machine was loaded by other work: timings are noisy**" if foreign > 0.1 else "")
                 + ".  ")
    for name, res in results.items():
        if res.get("note"):
            lines.append(f"Note ({name}): {res['note']}.  ")
    if a.note:
        lines.append(f"Note: {a.note}  ")
    lines.append("")
    lines.append("| date | machine | commit | renderer | samples/s | best samples/s | rays/s | time 64 spp (s) "
                 "| relMSE 64 spp | peak RSS (MiB) | time to equal relMSE / Mitsuba |")
    lines.append("|---|---|---|---|---:|---:|---:|---:|---:|---:|---|")
    for name, res in results.items():
        r = at_spp(res["rows"], 64)
        spp_lbl = "" if r["spp"] == 64 else f" (at {r['spp']} spp)"
        if name == mi_key:
            rat = "1 (baseline)"
        elif name in ratios:
            q = ratios[name]
            rat = f"{q['ratio']:.2f} ({q['ratio_time_fit']:.2f})"
        else:
            rat = "—"
        rays = f"{r['rays_per_s'] / 1e6:.1f} M" if r["rays_per_s"] else "—"
        lines.append(f"| {date} | {mach} | {com} | {name} | {r['samples_per_s'] / 1e6:.2f} M "
                     f"| {throughput(res['rows']) / 1e6:.2f} M | {rays} | {r['time']:.3f}{spp_lbl} "
                     f"| {r['relmse']:.4g} | {res['peak_rss_mib']:.0f} | {rat} |")
    if ratios and mi_key:
        m64 = at_spp(results[mi_key]["rows"], 64)
        parts = [f"{n}: **{q['ratio']:.2f}** (needs {q['spp']:.0f} spp, {q['how']})" for n, q in ratios.items()]
        lines.append("")
        lines.append(f"Time to equal relMSE, caustica / Mitsuba, at Mitsuba's {m64['spp']}-spp relMSE "
                     f"{m64['relmse']:.4g}: " + "; ".join(parts) + ".")
    with open(RESULTS, "a") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
