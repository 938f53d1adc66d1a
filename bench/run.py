#!/usr/bin/env python3
"""The standard benchmark (`make bench`): built-in scenes x integrators at equal time, errors against cached
references, Mitsuba 3 as a peer on `cornell`, time-to-equal-error ratios, JSON results and rows in RESULTS.md.

    .venv/bin/python bench/run.py              # the standard set, about 5 minutes once references are cached
    .venv/bin/python bench/run.py --quick      # smaller images, shorter budgets, one seed: about 1 minute
    make bench                                 # = build, then .venv/bin/python bench/run.py
    make bench BENCH_ARGS=--quick

The standard set (STANDARD below):
  cornell           path, sppm, pppm; Mitsuba 3 `path` as the peer (when `import mitsuba` works; see
                    bench/install-mitsuba.sh). Mitsuba's cornell_box() with a box filter, max_depth 8 and
                    rr_depth 5, as in bench/bench_cornell.py (whose Mitsuba set-up functions this reuses).
  smallvcm-spheres  path, sppm, pppm, vcm (glass and mirror spheres: caustics path tracing finds slowly)
  point-in-glass    sppm, pppm, vcm (a point light inside glass: path tracing renders it black, so it is left
                    out)
All square, at --size (default 128x128; --quick 64x64), box filter.

What it does:
  1. References (bench/out/refs/, made on first use, each with a JSON sidecar: scene, size, integrator, spp,
     seed, commit, seconds): path tracing at --ref-spp (default 4096, also with --quick), except point-in-glass,
     whose reference is pppm at the same number of passes (path tracing cannot render it; the reference is
     then itself a photon-map estimate, whose bias the photon mappers measured against it partly share).
  2. Every configuration renders for each budget of --budgets seconds (default 2 and 8; --quick 0.5 and 2)
     with seeds 1..--seeds (default 2; --quick 1): caustica with render_job(time=budget), whole passes until
     the budget is spent; Mitsuba in renders of a fixed spp chunk (its first render at a spp JIT-compiles the
     kernel: a warm-up render comes first) with successive seeds until the budget is spent, averaged (exact
     for the box filter). Renders of one seed and budget go scene by scene, configuration by configuration,
     in a rotating order, so that load from other work on the machine hits them alike; one 1-spp warm-up
     render per scene and integrator comes first.
  3. Errors against the reference: relMSE = mean over pixels and channels of (x - r)^2 / (r^2 + 0.01)
     (caustica.metrics.relmse) and mean LDR-FLIP (caustica.metrics.flip), averaged over the seeds; the time
     is the render's own measured seconds (caustica: stats["seconds"]; Mitsuba: wall time of its renders).
  4. Time-to-equal-error ratio of A against B (B: the scene's baseline, path tracing, or sppm on
     point-in-glass; and Mitsuba on cornell) at the largest budget: for an unbiased estimator relMSE falls as
     1/time, so relMSE x time is constant and A reaches B's error in t_A x relMSE_A / relMSE_B; the ratio is
     (relMSE_A x t_A) / (relMSE_B x t_B). Below 1: A needs less time for the same error. The photon mappers
     are biased (consistent): their relMSE falls more slowly than 1/time, so the ratio is a statement about
     this budget only. The measured exponent between the two budgets (d log relMSE / d log time, -1 for the
     1/time law) is printed and stored next to each ratio, and a second ratio that uses it instead of -1.
  5. Writes bench/out/results-<UTC date and time>.json (every render's figures, the references, the ratios)
     and appends a block of rows to bench/RESULTS.md (unless --no-append).
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
OUT_DIR = os.path.join(HERE, "out")
REF_DIR = os.path.join(OUT_DIR, "refs")
RESULTS = os.path.join(HERE, "RESULTS.md")
sys.path.insert(0, HERE)

import bench_cornell as bc  # noqa: E402  (Mitsuba set-up, machine/commit, CPU accounting)

MITSUBA = "mitsuba"   # the configuration name of the peer
STANDARD = [
    {"scene": "cornell", "integrators": ["path", "sppm", "pppm"], "baseline": "path", "peer": True,
     "max_depth": bc.MAX_DEPTH, "rr_depth": bc.RR_DEPTH, "ref": "path"},
    {"scene": "smallvcm-spheres", "integrators": ["path", "sppm", "pppm", "vcm"], "baseline": "path", "peer": False,
     "max_depth": None, "rr_depth": None, "ref": "path"},
    {"scene": "point-in-glass", "integrators": ["sppm", "pppm", "vcm"], "baseline": "sppm", "peer": False,
     "max_depth": None, "rr_depth": None, "ref": "pppm"},
]
REF_SEED = 1_000_003
MODES = {"default": {"size": 128, "budgets": [2.0, 8.0], "seeds": 2, "ref_spp": 4096},
         "quick": {"size": 64, "budgets": [0.5, 2.0], "seeds": 1, "ref_spp": 4096}}


def log(msg: str = "") -> None:
    print(msg, flush=True)


# ------------------------------------------------------------------------------------------------ caustica
def load(entry: dict, size: int):
    import caustica
    return caustica.load_scene(entry["scene"], width=size, height=size, filter="box")


def render_opts(entry: dict) -> dict:
    kw = {}
    if entry["max_depth"] is not None:
        kw["max_depth"] = entry["max_depth"]
    if entry["rr_depth"] is not None:
        kw["rr_depth"] = entry["rr_depth"]
    return kw


def reference(entry: dict, size: int, spp: int, com: str, fresh: bool) -> tuple[np.ndarray, dict]:
    """The scene's reference, cached in bench/out/refs/ with a JSON sidecar."""
    import caustica
    os.makedirs(REF_DIR, exist_ok=True)
    d, rr = entry["max_depth"], entry["rr_depth"]
    stem = (f"{entry['scene']}_{size}x{size}_box_{entry['ref']}_{spp}spp_seed{REF_SEED}"
            + (f"_d{d}" if d is not None else "") + (f"_rr{rr}" if rr is not None else ""))
    path = os.path.join(REF_DIR, stem + ".exr")
    meta_path = os.path.join(REF_DIR, stem + ".json")
    if not fresh and os.path.exists(path) and os.path.exists(meta_path):
        with open(meta_path) as f:
            return caustica.read_image(path), json.load(f)
    log(f"reference {entry['scene']}: {entry['ref']}, {spp} {'spp' if entry['ref'] == 'path' else 'passes'} at "
        f"{size}x{size} (first use; cached in {os.path.relpath(REF_DIR, ROOT)}) ...")
    t = time.perf_counter()
    r = caustica.render_job(load(entry, size), integrator=entry["ref"], spp=spp, seed=REF_SEED,
                            **render_opts(entry))
    if r.interrupted:
        raise KeyboardInterrupt
    meta = {"scene": entry["scene"], "size": [size, size], "filter": "box", "integrator": entry["ref"], "spp": spp,
            "seed": REF_SEED, "max_depth": d, "rr_depth": rr, "commit": com,
            "date": _dt.datetime.now(_dt.timezone.utc).isoformat(), "seconds": time.perf_counter() - t,
            "mean": float(r.image.mean())}
    caustica.write_image(path, r.image)
    with open(meta_path, "w") as f:
        json.dump(meta, f, indent=1)
    log(f"  done in {meta['seconds']:.0f} s")
    return r.image, meta


# ------------------------------------------------------------------------------------------------ Mitsuba
def mitsuba_available() -> bool:
    import importlib.util
    try:
        return importlib.util.find_spec("mitsuba") is not None
    except (ImportError, ValueError):
        return False


class MitsubaPeer:
    """Mitsuba 3's cornell_box() at the benchmark's size, set up by bench_cornell's _mitsuba_setup (best
    variant, LLVM found or scalar fallback) with bench_cornell's integrator settings; images oriented like
    the reference by bench_cornell's _orient."""

    def __init__(self, size: int, ref: np.ndarray):
        if not os.environ.get("DRJIT_LIBLLVM_PATH"):
            llvm = bc.find_libllvm()
            if llvm:
                os.environ["DRJIT_LIBLLVM_PATH"] = llvm           # before Dr.Jit loads its LLVM backend
        self.mi, self.variant, self.note = bc._mitsuba_setup({"variant": "llvm_ad_rgb", "threads": 0})
        d = self.mi.cornell_box()
        # bench_cornell._mitsuba_scene builds the same scene at its fixed 256x256; only the size differs here.
        d["sensor"]["film"]["rfilter"] = {"type": "box"}
        d["sensor"]["film"]["width"] = d["sensor"]["film"]["height"] = size
        d["integrator"] = {"type": "path", "max_depth": bc.MAX_DEPTH, "rr_depth": bc.RR_DEPTH}
        self.scene = self.mi.load_dict(d)
        self.chunk = min(64, max(1, round(524288 / (size * size))))  # about half a million samples per render
        img = np.array(self.mi.render(self.scene, spp=self.chunk, seed=999_999))   # warm-up: JIT compile
        self.orient, self.flip = bc._orient(img, ref)
        self.version = self.mi.__version__

    def render(self, budget: float, seed: int) -> tuple[np.ndarray, float, int]:
        acc, n, t0 = None, 0, time.perf_counter()
        while True:
            img = np.array(self.mi.render(self.scene, spp=self.chunk, seed=seed * 100_003 + n), dtype=np.float64)
            acc = img if acc is None else acc + img
            n += 1
            if time.perf_counter() - t0 >= budget:
                break
        secs = time.perf_counter() - t0
        return np.ascontiguousarray(self.flip((acc / n).astype(np.float32))), secs, n * self.chunk


# ------------------------------------------------------------------------------------------------ analysis
def ratio(a: dict, b: dict) -> float:
    """Time-to-equal-error ratio A/B under relMSE x time = constant."""
    return (a["relmse"] * a["seconds"]) / (b["relmse"] * b["seconds"])


def exponent(rows: list[dict]) -> float | None:
    """Measured d log relMSE / d log time between the smallest and the largest budget."""
    if len(rows) < 2:
        return None
    lo, hi = rows[0], rows[-1]
    if hi["seconds"] <= lo["seconds"] or lo["relmse"] <= 0 or hi["relmse"] <= 0:
        return None
    return math.log(hi["relmse"] / lo["relmse"]) / math.log(hi["seconds"] / lo["seconds"])


def ratio_fitted(a: dict, b: dict, k: float | None) -> float | None:
    """The ratio when A's relMSE falls as time^k (k measured) rather than 1/time: A reaches B's error at
    t_A (relMSE_B / relMSE_A)^(1/k)."""
    if k is None or k > -0.3:            # too flat (or noisy) to extrapolate along
        return None
    return a["seconds"] * (b["relmse"] / a["relmse"]) ** (1.0 / k) / b["seconds"]


def summarise(runs: list[dict], budgets: list[float]) -> dict:
    """{scene: {config: [per-budget means: budget, seconds, relmse, flip, passes]}}"""
    out = {}
    for r in runs:
        out.setdefault(r["scene"], {}).setdefault(r["config"], {}).setdefault(r["budget"], []).append(r)
    res = {}
    for scene, cfgs in out.items():
        res[scene] = {}
        for cfg, by_b in cfgs.items():
            rows = []
            for b in budgets:
                rs = by_b.get(b, [])
                if rs:
                    rows.append({"budget": b, "seconds": float(np.mean([x["seconds"] for x in rs])),
                                 "relmse": float(np.mean([x["relmse"] for x in rs])),
                                 "flip": float(np.mean([x["flip"] for x in rs])),
                                 "passes": float(np.mean([x["passes"] for x in rs])), "n": len(rs)})
            res[scene][cfg] = rows
    return res


# ------------------------------------------------------------------------------------------------ main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="64x64, budgets 0.5 and 2 s, one seed (about a minute)")
    ap.add_argument("--size", type=int, default=None, help="image width = height (default 128; quick 64)")
    ap.add_argument("--budgets", type=float, nargs="+", default=None, help="seconds per render (default 2 8)")
    ap.add_argument("--seeds", type=int, default=None, help="renders per configuration and budget (default 2)")
    ap.add_argument("--ref-spp", type=int, default=None, help="reference spp/passes (default 4096, also with --quick)")
    ap.add_argument("--scenes", nargs="+", default=None, help="a subset of the standard scenes")
    ap.add_argument("--no-mitsuba", action="store_true", help="leave the peer out")
    ap.add_argument("--fresh-ref", action="store_true", help="re-render the cached references")
    ap.add_argument("--no-append", action="store_true", help="do not append to bench/RESULTS.md")
    ap.add_argument("--note", default="", help="free text for the RESULTS.md block")
    a = ap.parse_args(argv)
    mode = MODES["quick" if a.quick else "default"]
    size = a.size or mode["size"]
    budgets = sorted(set(a.budgets or mode["budgets"]))
    seeds = a.seeds or mode["seeds"]
    ref_spp = a.ref_spp or mode["ref_spp"]
    if size <= 0 or seeds <= 0 or ref_spp <= 0 or any(not (b > 0 and math.isfinite(b)) for b in budgets):
        ap.error("--size, --seeds, --ref-spp and --budgets must be positive")
    names = [e["scene"] for e in STANDARD]
    if a.scenes:
        bad = [s for s in a.scenes if s not in names]
        if bad:
            ap.error(f"unknown scene(s) {', '.join(bad)} (the standard set: {', '.join(names)})")
    entries = [e for e in STANDARD if not a.scenes or e["scene"] in a.scenes]

    import caustica
    from caustica import metrics

    os.makedirs(OUT_DIR, exist_ok=True)
    started = _dt.datetime.now(_dt.timezone.utc)
    com = bc.commit()
    mach = bc.machine()
    cmd_line = " ".join([".venv/bin/python", "bench/run.py"] + (sys.argv[1:] if argv is None else list(argv)))
    log(f"machine: {mach}; commit {com}; size {size}x{size}; budgets {budgets} s; seeds {seeds}; "
        f"reference {ref_spp} spp")

    refs, ref_meta, scenes = {}, {}, {}
    for e in entries:
        refs[e["scene"]], ref_meta[e["scene"]] = reference(e, size, ref_spp, com, a.fresh_ref)
        scenes[e["scene"]] = load(e, size)

    peer, peer_info = None, {"used": False}
    if not a.no_mitsuba and any(e["peer"] for e in entries):
        if mitsuba_available():
            try:
                peer = MitsubaPeer(size, refs["cornell"])
                peer_info = {"used": True, "version": peer.version, "variant": peer.variant, "note": peer.note,
                             "orientation": peer.orient, "chunk_spp": peer.chunk,
                             "llvm": os.environ.get("DRJIT_LIBLLVM_PATH")}
                log(f"peer: Mitsuba {peer.version} {peer.variant}, renders of {peer.chunk} spp"
                    + (f" ({peer.note})" if peer.note else ""))
            except Exception as ex:  # a broken peer must not stop caustica's benchmark
                peer_info = {"used": False, "why": f"{type(ex).__name__}: {str(ex).splitlines()[0][:200]}"}
                log(f"peer: Mitsuba failed to start ({peer_info['why']}); measuring caustica only")
        else:
            peer_info = {"used": False, "why": "mitsuba is not installed (bash bench/install-mitsuba.sh)"}
            log(f"peer: {peer_info['why']}; measuring caustica only")

    # --- warm-up: one short render per scene and integrator (thread pool, acceleration structure, caches)
    for e in entries:
        for cfg in e["integrators"]:
            caustica.render_job(scenes[e["scene"]], integrator=cfg, spp=1, seed=0, **render_opts(e))

    # --- measurements
    runs = []
    busy0, own0, wall0 = bc.cpu_busy_seconds(), bc.own_cpu_seconds(), time.perf_counter()
    turn = 0
    for seed in range(1, seeds + 1):
        for budget in budgets:
            for e in entries:
                cfgs = list(e["integrators"]) + ([MITSUBA] if (e["peer"] and peer is not None) else [])
                k = turn % len(cfgs)
                turn += 1
                for cfg in cfgs[k:] + cfgs[:k]:
                    if cfg == MITSUBA:
                        img, secs, spp = peer.render(budget, seed)
                        passes, photons = spp, 0
                    else:
                        r = caustica.render_job(scenes[e["scene"]], integrator=cfg, time=budget, seed=seed,
                                                **render_opts(e))
                        if r.interrupted:
                            raise KeyboardInterrupt
                        img, secs = r.image, float(r.stats["seconds"])
                        passes, photons = int(r.stats["passes"]), int(r.stats.get("photons") or 0)
                    ref = refs[e["scene"]]
                    run = {"scene": e["scene"], "config": cfg, "budget": budget, "seed": seed, "seconds": secs,
                           "passes": passes, "photons": photons, "relmse": metrics.relmse(img, ref),
                           "flip": metrics.flip(img, ref, mode="ldr"), "mean": float(np.mean(img))}
                    runs.append(run)
                    log(f"  seed {seed} {budget:g} s  {e['scene']:17s} {cfg:8s} {passes:6d} "
                        f"{'spp' if cfg in ('path', MITSUBA) else 'passes':6s} {secs:6.2f} s  "
                        f"relMSE {run['relmse']:.5f}  FLIP {run['flip']:.4f}")
    wall = time.perf_counter() - wall0
    foreign = max(0.0, (bc.cpu_busy_seconds() - busy0) - (bc.own_cpu_seconds() - own0)) / wall

    # --- ratios
    summary = summarise(runs, budgets)
    summary = {e["scene"]: {c: summary[e["scene"]][c] for c in e["integrators"] + [MITSUBA] if c in summary[e["scene"]]}
               for e in entries}
    ratios = []
    for e in entries:
        s = summary[e["scene"]]
        against = [e["baseline"]] + ([MITSUBA] if MITSUBA in s else [])
        for cfg, rows in s.items():
            k = exponent(rows)
            for b in against:
                if b == cfg or b not in s:
                    continue
                A, B = s[cfg][-1], s[b][-1]
                ratios.append({"scene": e["scene"], "config": cfg, "against": b, "budget": A["budget"],
                               "ratio": ratio(A, B), "exponent": k, "ratio_fitted_exponent": ratio_fitted(A, B, k)})
    log("")
    log(f"time to equal relMSE at the {budgets[-1]:g}-s budget, (relMSE x time) / (relMSE x time of the other); "
        f"below 1: faster to the same error")
    for q in ratios:
        fe = f" ({q['ratio_fitted_exponent']:.3f} with the measured exponent)" if q["ratio_fitted_exponent"] else ""
        ex = f" (relMSE ~ time^{q['exponent']:.2f})" if q["exponent"] is not None else ""
        log(f"  {q['scene']:17s} {q['config']:8s} / {q['against']:8s} {q['ratio']:7.3f}{fe}{ex}")
    log(f"other work on the machine: {foreign:.2f} of {os.cpu_count()} cores on average during the timed phase "
        f"({wall:.0f} s)")

    # --- outputs
    stamp = started.strftime("%Y%m%d-%H%M%S")
    jpath = os.path.join(OUT_DIR, f"results-{stamp}.json")
    with open(jpath, "w") as f:
        json.dump({"date": started.isoformat(), "command": cmd_line, "machine": mach, "commit": com,
                   "commit_at_end": bc.commit(), "settings": {"size": size, "budgets": budgets, "seeds": seeds,
                                                             "ref_spp": ref_spp, "quick": a.quick},
                   "standard": entries, "references": ref_meta, "peer": peer_info, "foreign_cores": foreign,
                   "runs": runs, "summary": summary, "ratios": ratios}, f, indent=1)
    log(f"results: {os.path.relpath(jpath, ROOT)}")
    if not a.no_append:
        append_results(started, mach, com, cmd_line, size, budgets, seeds, ref_spp, ref_meta, peer_info, foreign,
                       summary, ratios, a.note, os.path.relpath(jpath, ROOT))
        log(f"appended to {os.path.relpath(RESULTS, ROOT)}")
    return 0


SECTION_MARK = "# Standard set (`make bench`, bench/run.py)"
SECTION_HEADER = SECTION_MARK + """

Written by `bench/run.py` (one block per run, appended; `make bench` runs it). Built-in scenes x integrators
at equal time, errors against cached long renders (bench/out/refs/), Mitsuba 3 as a peer on `cornell`. The
method is in the script's docstring. Columns:

- **machine**, **commit** (`-dirty`: tracked files had uncommitted changes), **command**: as the block says.
- **scene**, **renderer**: caustica's integrator, or Mitsuba with version and variant.
- **budget (s)**: the time each render was given; **passes**: passes (spp) it completed (mean over seeds).
- **relMSE**: mean (x - r)^2 / (r^2 + 0.01) against the scene's reference; **FLIP**: mean LDR-FLIP;
  both averaged over the seeds.
- **time to equal relMSE**: (relMSE x time) / (relMSE x time of the scene's baseline, path tracing, or sppm
  on point-in-glass), at the largest budget: relMSE x time is constant for an unbiased 1/N estimator, so this
  is the time the renderer needs for the baseline's error over the baseline's time. Below 1: faster. In
  brackets, on `cornell`: the same against Mitsuba. **exponent**: measured d log relMSE / d log time
  between the budgets (-1 is the 1/time law; photon mappers, being biased, fall more slowly).
"""


def append_results(started, mach, com, cmd_line, size, budgets, seeds, ref_spp, ref_meta, peer_info, foreign,
                   summary, ratios, note, jrel):
    text = open(RESULTS).read() if os.path.exists(RESULTS) else ""
    date = started.strftime("%Y-%m-%d %H:%M UTC")
    lines = []
    if SECTION_MARK not in text:
        lines.append("\n" + SECTION_HEADER)
    lines.append(f"\n## Standard set, {date}, commit {com}\n")
    lines.append(f"Command: `{cmd_line}`  ")
    lines.append(f"Machine: {mach}; other work on the machine took {foreign:.2f} of {os.cpu_count()} cores on "
                 f"average during the timed phase"
                 + (" — **timings are noisy**" if foreign > 0.1 else "") + ".  ")
    refs = "; ".join(f"{s}: {m['integrator']} {m['spp']} {'spp' if m['integrator'] == 'path' else 'passes'}"
                     for s, m in ref_meta.items())
    lines.append(f"Settings: {size}x{size}, box filter; budgets {', '.join(f'{b:g}' for b in budgets)} s; "
                 f"{seeds} seed(s); references {refs}. JSON: `{jrel}` (not committed).  ")
    if peer_info.get("used"):
        lines.append(f"Peer: Mitsuba {peer_info['version']} {peer_info['variant']} (renders of "
                     f"{peer_info['chunk_spp']} spp until the budget is spent)"
                     + (f"; {peer_info['note']}" if peer_info.get("note") else "") + ".  ")
    else:
        lines.append(f"Peer: none ({peer_info.get('why', 'not requested')}).  ")
    shares = [f"{s}: {100 * rows[-1]['passes'] / ref_meta[s]['spp']:.0f}%" for s, c in summary.items()
              if ref_meta[s]["integrator"] == "path" and "path" in c for rows in [c["path"]]]
    if shares:
        lines.append("Reference noise: the reference's own relMSE, added to every measured relMSE, is about path's "
                     "measured relMSE x path's spp at the largest budget / the reference's spp, i.e. this share of "
                     "it: " + ", ".join(shares) + "; it pulls every ratio towards 1.  ")
    if note:
        lines.append(f"Note: {note}  ")
    lines.append("")
    lines.append("| machine | commit | command | scene | renderer | budget (s) | passes | relMSE | FLIP "
                 "| time to equal relMSE | exponent |")
    lines.append("|---|---|---|---|---|---:|---:|---:|---:|---|---:|")
    by = {(q["scene"], q["config"], q["against"]): q for q in ratios}
    for scene, cfgs in summary.items():
        base = next(e["baseline"] for e in STANDARD if e["scene"] == scene)
        for cfg, rows in cfgs.items():
            name = (f"Mitsuba {peer_info.get('version')} {peer_info.get('variant')}" if cfg == MITSUBA
                    else f"caustica {cfg}")
            for i, r in enumerate(rows):
                last = i == len(rows) - 1
                rat = "—"
                if last:
                    q = by.get((scene, cfg, base))
                    rat = "1 (baseline)" if cfg == base else (f"**{q['ratio']:.3f}**" if q else "—")
                    m = by.get((scene, cfg, MITSUBA))
                    if m:
                        rat += f" ({m['ratio']:.3f} vs Mitsuba)"
                    elif cfg == MITSUBA and q:
                        rat = f"**{q['ratio']:.3f}**"
                qk = next((q["exponent"] for q in ratios if q["scene"] == scene and q["config"] == cfg), None)
                if qk is None and cfg == base:
                    qk = exponent(rows)
                ex = f"{qk:.2f}" if (last and qk is not None) else ""
                lines.append(f"| {mach} | {com} | `{cmd_line}` | {scene} | {name} | {r['budget']:g} "
                             f"| {r['passes']:.0f} | {r['relmse']:.5f} | {r['flip']:.4f} | {rat} | {ex} |")
    with open(RESULTS, "a") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
