"""Studies of what users see: how many samples an image needs, and what that costs.

    import caustica
    res = caustica.study.realtime("cornell", integrators=["path", "sppm"], thresholds=[0.2, 0.1, 0.05],
                                  max_spp=256, seeds=3, out="out/realtime-cornell")
    for row in res["table"]:
        print(row["integrator"], row["threshold"], row["spp_needed"], row["frame_ms"], row["speedup_missing"])

`realtime` answers: for each integrator, how many samples per pixel (passes, for the photon
integrators) bring the mean FLIP error against a converged reference below each threshold, and
how long a 1920x1080 frame with that many samples takes at the throughput measured on this
machine's CPU or GPU (`device`), compared with the 16.7 ms of a 60 Hz frame.

Method (also written into every report):
  * The scene is rendered at a small size (default: the scene's aspect ratio at 1/64 of the
    pixels of 1920x1080, i.e. about 32 400 pixels) and the result is scaled to 1920x1080 by
    pixel count: the spp needed is taken as it is (per-pixel noise depends on the samples per
    pixel, not on the resolution), and throughput in samples per second is assumed to be
    independent of the resolution (cost proportional to pixels; photon integrators trace one
    photon path per pixel per pass by default, so their cost scales likewise).
  * FLIP is evaluated on the small image at FLIP's default 67 pixels per degree, i.e. as if the
    small image were shown with the pixel density of the 1080p display: FLIP's spatial filters
    then see the per-pixel noise at the same angular scale as on the real display. What this
    leaves out: at 1080p each pixel covers a smaller part of the scene, so edges and texture
    vary less within a pixel; the small size therefore slightly overestimates the spp needed.
  * Reference: a long render (default: path tracing, 4096 spp) at the small size, cached in the
    output folder with a JSON sidecar of its parameters.
  * For each integrator and each spp in 1, 2, 4, ... up to the cap, one render per seed (seeds
    1..N; the reference uses another seed); mean FLIP is averaged over the seeds. The photon
    integrators are progressive (the radius shrinks over passes), so each spp is its own render.
  * spp needed for a threshold: the first measured spp whose mean FLIP is at or below the
    threshold, interpolated log-log with the spp before it; at the first spp already: "<= 1";
    not reached by the cap: extrapolated with the log-log least-squares slope of the last three
    points (marked), unless that slope is flatter than -0.1 (then: not reached).
  * Throughput: samples (camera paths per pixel times pixels; photon integrators: passes times
    pixels) per second of render time. `throughput_at="small"` (the CPU's default): the best over
    the seeds of the curve's renders at the largest two spp (fixed costs amortised; the best
    because load from other work only slows renders), scaled to 1080p by pixel count.
    `throughput_at="1080p"` (the GPU's default: a GPU needs about a million paths in flight to be
    busy, which the small size does not give it, so pixel-count scaling does not hold there):
    renders of `throughput_spp` passes at the scene's aspect with 1920x1080's pixel count, the
    best of max(2, seeds) renders (the first also warms the device up).
  * Frame time at 1920x1080 = spp needed x 2 073 600 / throughput; speed-up still missing =
    frame time / 16.7 ms (below 1: fast enough already).
  * Device: `device="cuda"` renders the reference, the curves and the throughput renders on the
    GPU (the integrators the CUDA backend runs: _api.CUDA_INTEGRATORS; a reference integrator it
    does not run renders on the CPU). The noise per spp does not depend on the device (the
    drivers share their sampling code; CPU/GPU parity tests), the throughput does.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import math
import os
import platform
import subprocess
import time as _time
from typing import Callable, Iterable, Optional, Sequence, Union

import numpy as np

from . import _api

InputError = _api.InputError

THRESHOLDS = (0.2, 0.1, 0.05)
TARGET_SIZE = (1920, 1080)
TARGET_PIXELS = TARGET_SIZE[0] * TARGET_SIZE[1]
FRAME_MS = 1000.0 / 60.0
DEFAULT_MAX_SPP = 256
DEFAULT_SEEDS = 3
DEFAULT_REF_SPP = 4096
REF_SEED = 1_000_003
THROUGHPUT_AT = ("small", "1080p")
DEFAULT_THROUGHPUT_SPP = 4


def device_note(device: str, description: str, throughput_size: Sequence[int], measured_at_target: bool) -> str:
    """One paragraph for the report and the command line: where the figures come from."""
    tw, th = throughput_size
    how = (f"measured at {tw}x{th}" if measured_at_target
           else "measured at the small size and scaled to 1080p by pixel count")
    if device == "cpu":
        return (f"Renders on the CPU ({description}); throughput {how}. These are CPU figures: caustica's CUDA "
                f"backend runs {', '.join(_api.CUDA_INTEGRATORS)} on NVIDIA GPUs, and `--device cuda` runs this "
                "study there (throughput measured at 1080p).")
    return f"Renders on {device} ({description}), the CUDA backend's wavefront drivers; throughput {how}."


# ------------------------------------------------------------------------------------------- metrics
def _flip(img: np.ndarray, ref: np.ndarray, mode: str) -> float:
    from . import metrics
    return float(metrics.flip(img, ref, mode=mode))


def _relmse(img: np.ndarray, ref: np.ndarray) -> float:
    from . import metrics
    return float(metrics.relmse(img, ref))


# ------------------------------------------------------------------------------------------- helpers
from ._provenance import machine as _machine  # noqa: E402


from ._provenance import commit as _commit  # noqa: E402
from ._provenance import cpu_busy_seconds as _cpu_busy_seconds  # noqa: E402
from ._provenance import own_cpu_seconds as _own_cpu_seconds  # noqa: E402


def spp_levels(max_spp: int) -> list[int]:
    """1, 2, 4, ... up to max_spp (max_spp itself included)."""
    out, s = [], 1
    while s < max_spp:
        out.append(s)
        s *= 2
    out.append(max_spp)
    return out


def default_size(width: int, height: int, pixels: int = TARGET_PIXELS // 64) -> tuple[int, int]:
    """The scene's aspect ratio at about `pixels` pixels."""
    aspect = width / height
    h = max(1, round(math.sqrt(pixels / aspect)))
    return max(1, round(h * aspect)), h


def spp_needed(levels: Sequence[float], flips: Sequence[float], threshold: float) -> tuple[Optional[float], str]:
    """spp at which mean FLIP falls to `threshold`, from the curve (levels ascending, flips their mean FLIP).

    Returns (spp, how): how is "interpolated" (log-log between the first measured spp at or below the
    threshold and the one before it), "<=" (already at the first level; spp is that level),
    "extrapolated" (log-log least-squares line through the last three points, not reached by the cap)
    or "not reached" (spp None: the curve's tail is flatter than a slope of -0.1)."""
    pts = [(float(s), float(f)) for s, f in zip(levels, flips)]
    for i, (s, f) in enumerate(pts):
        if f <= threshold:
            if i == 0:
                return s, "<="
            s0, f0 = pts[i - 1]
            if f0 == f:
                return s, "interpolated"
            a = (math.log(threshold) - math.log(f0)) / (math.log(f) - math.log(f0))
            return math.exp(math.log(s0) + a * (math.log(s) - math.log(s0))), "interpolated"
    tail = [(s, f) for s, f in pts if f > 0][-3:]
    if len(tail) >= 2:
        b, a = np.polyfit(np.log([p[0] for p in tail]), np.log([p[1] for p in tail]), 1)
        if b < -0.1:
            return float(math.exp((math.log(threshold) - a) / b)), "extrapolated"
    return None, "not reached"


def _check_list(name, values, ok, expects):
    try:
        vals = list(values)
    except TypeError:
        raise InputError(f"{name}: expected {expects}, got {values!r}") from None
    if not vals:
        raise InputError(f"{name}: expected at least one value")
    for v in vals:
        if isinstance(v, bool) or not ok(v):
            raise InputError(f"{name}: expected {expects}, got {v!r}")
    return vals


def _pos_int(name, v):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v <= 0:
        raise InputError(f"{name} must be a positive integer, got {v!r}")
    return int(v)


def _scene_id(scene) -> dict:
    """What identifies the scene for the reference cache: a built-in name, or a file's absolute path,
    size and modification time."""
    if isinstance(scene, (str, os.PathLike)):
        s = os.fspath(scene)
        if os.path.exists(s):
            st = os.stat(s)
            return {"file": os.path.abspath(s), "bytes": st.st_size, "mtime": st.st_mtime}
        return {"builtin": s}
    raise InputError("scene: expected a built-in name or a scene file path")


# ------------------------------------------------------------------------------------------- the study
def realtime(scene: Union[str, os.PathLike], integrators: Optional[Iterable[str]] = None,
             thresholds: Iterable[float] = THRESHOLDS, size: Optional[tuple[int, int]] = None,
             max_spp: int = DEFAULT_MAX_SPP, seeds: int = DEFAULT_SEEDS, ref_spp: int = DEFAULT_REF_SPP,
             ref_integrator: str = "path", out: Union[str, os.PathLike, None] = None, flip_mode: str = "ldr",
             threads: int = 0, max_depth: Optional[int] = None, sampler: Optional[str] = None,
             camera: Optional[str] = None, params: Optional[dict] = None, variant: Optional[str] = None,
             fresh_ref: bool = False,
             device: str = "cpu", throughput_at: Optional[str] = None, throughput_spp: int = DEFAULT_THROUGHPUT_SPP,
             log: Optional[Callable[[str], None]] = None, command: Optional[str] = None) -> dict:
    """The real-time noise study of `scene` (a built-in name or a scene file).

    For each integrator (default: all of caustica.integrators()), renders at spp 1, 2, 4, ... max_spp
    with seeds 1..`seeds` at the small `size` (default: the scene's aspect at 1/64 of 1920x1080's
    pixels), measures mean FLIP (caustica.metrics.flip, `flip_mode` "ldr" or "hdr") against a reference
    (`ref_integrator` at `ref_spp`, cached under `out`/reference when `out` is given) and the throughput,
    and from them, for each threshold, the spp needed, the frame time at 1920x1080 and the speed-up still
    missing for 16.7 ms (see the module's docstring for the method and its assumptions).
    `device`: "cpu" (default), "cuda" or "cuda:N" (default integrators there: those the CUDA backend runs).
    `throughput_at`: "small" (scale the curve renders' throughput by pixel count; the CPU's default) or
    "1080p" (measure it with renders of `throughput_spp` passes at 1920x1080's pixel count; the GPU's default).

    Returns a dict: "table" (a list of dicts, one per integrator and threshold: integrator, threshold,
    spp_needed (None when not reached), how, samples_per_s, samples_per_s_1080p (frames of 1 spp per
    second at 1080p), frame_ms, speedup_missing), "curves" ({integrator: [{spp, flip, flip_seeds, relmse,
    seconds}]}), "throughput", "reference", "settings", "machine", "commit", "foreign_cores" (CPU other
    work took meanwhile), and "report" (the report's path, when `out` is given: report.md, plots as PNG
    and SVG, results.json)."""
    _api._check_device_name(device)
    on_gpu = device != "cpu"
    all_integrators = _api.integrators()
    integ = [i for i in all_integrators if not on_gpu or i in _api.CUDA_INTEGRATORS] if integrators is None \
        else _check_list("integrators", integrators, lambda v: isinstance(v, str), "integrator names")
    for i in integ + [ref_integrator]:
        if _api.split_integrator_variant(i)[0] not in all_integrators:
            raise InputError(f"unknown integrator '{i}' (allowed: {', '.join(all_integrators)}; variants: "
                             f"{', '.join(_api.variant_names())})")
    integ = list(dict.fromkeys(integ))
    if throughput_at is None:
        throughput_at = "1080p" if on_gpu else "small"
    if throughput_at not in THROUGHPUT_AT:
        raise InputError(f"throughput_at: expected 'small' or '1080p', got {throughput_at!r}")
    throughput_spp = _pos_int("throughput_spp", throughput_spp)
    thr = _check_list("thresholds", thresholds,
                      lambda v: isinstance(v, (int, float, np.floating)) and 0 < v < 1, "numbers in (0, 1)")
    thr = sorted({float(t) for t in thr}, reverse=True)
    max_spp = _pos_int("max_spp", max_spp)
    seeds = _pos_int("seeds", seeds)
    ref_spp = _pos_int("ref_spp", ref_spp)
    if flip_mode not in ("ldr", "hdr"):
        raise InputError(f"flip_mode: expected 'ldr' or 'hdr', got {flip_mode!r}")
    if size is not None:
        if not (isinstance(size, (tuple, list)) and len(size) == 2):
            raise InputError(f"size: expected (width, height), got {size!r}")
        size = (_pos_int("width", size[0]), _pos_int("height", size[1]))
    sid = _scene_id(scene)
    _api._check_device(device)  # after the checks above: "no GPU here" is not the first thing to say
    description = next((d["description"] for d in _api.devices()
                        if d["name"] == ("cuda:0" if device == "cuda" else device)), device)
    say = log or (lambda msg: None)

    base = _api.load_scene(scene, camera=camera, params=params, variant=variant)
    w, h = size if size is not None else default_size(base.width, base.height)
    tw, th = default_size(base.width, base.height, TARGET_PIXELS)  # the scene's aspect (before the next line)
    sc = _api.load_scene(base, width=w, height=h)  # base itself, at w x h
    pixels = w * h
    common = dict(threads=threads, max_depth=max_depth, sampler=sampler, device=device)
    started = _dt.datetime.now(_dt.timezone.utc)
    commit = _commit()

    # --- reference (cached)
    ref_key = {"scene": sid, "camera": camera, "params": params, "size": [w, h], "integrator": ref_integrator,
               "spp": ref_spp, "seed": REF_SEED, "max_depth": max_depth, "sampler": sampler,
               "version": _api.__version__}
    if variant is not None:  # absent otherwise: references cached before variants existed keep their keys
        ref_key["variant"] = variant
    digest = hashlib.sha1(json.dumps(ref_key, sort_keys=True, default=str).encode()).hexdigest()[:10]
    name = os.path.splitext(os.path.basename(sid.get("file", sid.get("builtin", "scene"))))[0]
    ref_meta = None
    ref_path = None
    if out is not None:
        out = os.fspath(out)
        try:
            os.makedirs(os.path.join(out, "reference"), exist_ok=True)
        except OSError as e:
            raise InputError(f"cannot write to '{out}': {e.strerror}") from None
        ref_path = os.path.join(out, "reference", f"ref-{name}-{w}x{h}-{ref_integrator}-{ref_spp}-{digest}.exr")
        if not fresh_ref and os.path.exists(ref_path) and os.path.exists(ref_path[:-4] + ".json"):
            ref = _api.read_image(ref_path)
            with open(ref_path[:-4] + ".json") as f:
                ref_meta = json.load(f)
            say(f"reference: cached {os.path.relpath(ref_path)} ({ref_meta.get('spp')} spp, rendered at commit "
                f"{ref_meta.get('commit')})")
    if ref_meta is None:
        say(f"reference: {ref_integrator}, {ref_spp} spp at {w}x{h} ...")
        t = _time.perf_counter()
        ref_base, ref_variant = _api.split_integrator_variant(ref_integrator)
        ref_device = device if ref_base in _api.CUDA_INTEGRATORS else "cpu"
        r = _api.render_job(sc, integrator=ref_base, spp=ref_spp, seed=REF_SEED, **dict(common, device=ref_device),
                            **ref_variant)
        if r.interrupted:
            raise KeyboardInterrupt
        ref = r.image
        ref_meta = dict(ref_key, seconds=_time.perf_counter() - t, commit=commit, date=started.isoformat(),
                        mean=float(np.mean(ref)), device=ref_device)
        say(f"  done in {ref_meta['seconds']:.1f} s")
        if ref_path is not None:
            _api.write_image(ref_path, ref)
            _api.write_image(ref_path[:-4] + ".png", ref)
            with open(ref_path[:-4] + ".json", "w") as f:
                json.dump(ref_meta, f, indent=1, default=str)
    ref_meta = dict(ref_meta, path=ref_path)
    if ref_spp < 16 * max_spp:
        say(f"note: the reference has {ref_spp} spp, less than 16 x the cap ({max_spp}): its own noise is "
            f"part of the FLIP measured at high spp")

    # --- curves
    levels = spp_levels(max_spp)
    curves, throughput = {}, {}
    busy0, own0, wall0 = _cpu_busy_seconds(), _own_cpu_seconds(), _time.perf_counter()
    for it in integ:
        rows = []
        for spp in levels:
            fl, rm, secs, rates = [], [], [], []
            for seed in range(1, seeds + 1):
                name_, variant = _api.split_integrator_variant(it)
                r = _api.render_job(sc, integrator=name_, spp=spp, seed=seed, **common, **variant)
                if r.interrupted:
                    raise KeyboardInterrupt
                s = max(float(r.stats["seconds"]), 1e-9)
                fl.append(_flip(r.image, ref, flip_mode))
                rm.append(_relmse(r.image, ref))
                secs.append(s)
                rates.append(r.stats["passes"] * pixels / s)
            rows.append({"spp": spp, "flip": float(np.mean(fl)), "flip_seeds": fl, "relmse": float(np.mean(rm)),
                         "seconds": secs, "samples_per_s": float(max(rates))})
            say(f"  {it:6s} {spp:5d} spp: mean FLIP {rows[-1]['flip']:.4f}, relMSE {rows[-1]['relmse']:.4g}, "
                f"{rows[-1]['samples_per_s'] / 1e6:.2f} M samples/s")
        curves[it] = rows
        top = rows[-2:] if len(rows) >= 2 else rows
        throughput[it] = float(max(r["samples_per_s"] for r in top))
    # --- throughput at 1080p's pixel count (a GPU is not busy at the small size)
    throughput_renders = {}
    if throughput_at == "1080p":
        big = _api.load_scene(base, width=tw, height=th)
        for it in integ:
            name_, variant = _api.split_integrator_variant(it)
            rates = []
            for seed in range(1, max(2, seeds) + 1):
                r = _api.render_job(big, integrator=name_, spp=throughput_spp, seed=seed, **common, **variant)
                if r.interrupted:
                    raise KeyboardInterrupt
                rates.append(r.stats["passes"] * tw * th / max(float(r.stats["seconds"]), 1e-9))
            throughput[it] = float(max(rates))
            throughput_renders[it] = rates
            say(f"  {it:6s} at {tw}x{th}: {throughput[it] / 1e6:.2f} M samples/s ({throughput_spp} passes, best of "
                f"{len(rates)})")
    wall = _time.perf_counter() - wall0
    foreign = max(0.0, (_cpu_busy_seconds() - busy0) - (_own_cpu_seconds() - own0)) / max(wall, 1e-9)

    # --- table
    table = []
    for it in integ:
        lv = [r["spp"] for r in curves[it]]
        fv = [r["flip"] for r in curves[it]]
        thr_small = throughput[it]
        for t in thr:
            n, how = spp_needed(lv, fv, t)
            row = {"integrator": it, "threshold": t, "spp_needed": n, "how": how, "samples_per_s": thr_small,
                   "frames_per_s_1spp_1080p": thr_small / TARGET_PIXELS, "frame_ms": None, "speedup_missing": None}
            if n is not None:
                row["frame_ms"] = 1000.0 * n * TARGET_PIXELS / thr_small
                row["speedup_missing"] = row["frame_ms"] / FRAME_MS
            table.append(row)

    res = {"scene": os.fspath(scene), "table": table, "curves": curves, "throughput": throughput,
           "reference": ref_meta, "machine": _machine(), "commit": commit, "date": started.isoformat(),
           "foreign_cores": foreign, "cores": os.cpu_count(), "device": device, "device_description": description,
           "gpu": description if on_gpu else None,
           "device_note": device_note(device, description, (tw, th), throughput_at == "1080p"),
           "throughput_renders": throughput_renders,
           "settings": {"integrators": integ, "thresholds": thr, "size": [w, h], "target_size": list(TARGET_SIZE),
                        "frame_ms": FRAME_MS, "max_spp": max_spp, "levels": levels, "seeds": seeds,
                        "ref_spp": ref_spp, "ref_integrator": ref_integrator, "flip_mode": flip_mode,
                        "flip_ppd": 67.0, "threads": threads, "max_depth": max_depth, "sampler": sampler,
                        "camera": camera, "params": params, "variant": variant, "device": device,
                        "throughput_at": throughput_at,
                        "throughput_size": [tw, th] if throughput_at == "1080p" else [w, h],
                        "throughput_spp": throughput_spp if throughput_at == "1080p" else None},
           "command": command, "report": None}
    if out is not None:
        res["report"] = write_report(res, out)
        say(f"report: {res['report']}")
    return res


# ------------------------------------------------------------------------------------------- report
def _fmt_spp(row) -> str:
    n = row["spp_needed"]
    if n is None:
        return "not reached"
    if row["how"] == "<=":
        return f"≤ {n:g}"
    s = f"{n:.1f}" if n < 100 else f"{n:.0f}"
    return f"~{s} (extrapolated)" if row["how"] == "extrapolated" else s


def _fmt_rate(v: float) -> str:
    return f"{v / 1e6:.2f} M" if v >= 1e5 else f"{v / 1e3:.1f} k"


def format_table(table: list[dict]) -> str:
    lines = ["| integrator | mean FLIP ≤ | spp needed | throughput (samples/s) | 1-spp frames/s at 1080p "
             "| frame time at 1080p (ms) | speed-up missing for 16.7 ms |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for r in table:
        ft = "—" if r["frame_ms"] is None else f"{r['frame_ms']:.0f}" if r["frame_ms"] >= 100 else f"{r['frame_ms']:.1f}"
        if r["speedup_missing"] is None:
            sp = "—"
        elif r["speedup_missing"] <= 1:
            sp = f"none ({r['speedup_missing']:.2f})"
        else:
            sp = f"{r['speedup_missing']:.0f}×" if r["speedup_missing"] >= 10 else f"{r['speedup_missing']:.1f}×"
        lines.append(f"| {r['integrator']} | {r['threshold']:g} | {_fmt_spp(r)} | {_fmt_rate(r['samples_per_s'])} "
                     f"| {r['frames_per_s_1spp_1080p']:.2f} | {ft} | {sp} |")
    return "\n".join(lines)


def _save_plot(plt, fig, ax, out: str, name: str) -> list[str]:
    """Grid, legend, layout; writes out/name.png and .svg and closes the figure; returns the paths."""
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    paths = []
    for ext in ("png", "svg"):
        paths.append(os.path.join(out, f"{name}.{ext}"))
        fig.savefig(paths[-1], dpi=120)
    plt.close(fig)
    return paths

def _plots(res: dict, out: str) -> list[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    written = []
    st = res["settings"]
    # FLIP vs spp
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for it, rows in res["curves"].items():
        ax.loglog([r["spp"] for r in rows], [r["flip"] for r in rows], "o-", label=it, ms=4)
    for t in st["thresholds"]:
        ax.axhline(t, color="0.6", lw=0.8, ls="--")
        ax.text(st["levels"][0], t, f" {t:g}", va="bottom", ha="left", fontsize=8, color="0.4")
    ax.set_xlabel("samples per pixel (photon integrators: passes)")
    ax.set_ylabel(f"mean FLIP ({st['flip_mode'].upper()}, {st['flip_ppd']:.0f} ppd)")
    ax.set_title(f"{os.path.basename(res['scene'])}: mean FLIP vs spp at {st['size'][0]}x{st['size'][1]} "
                 f"({st['seeds']} seeds)", fontsize=10)
    written += _save_plot(plt, fig, ax, out, "flip_vs_spp")
    # FLIP vs frame time at 1080p
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for it, rows in res["curves"].items():
        thr = res["throughput"][it]
        ax.loglog([1000.0 * r["spp"] * TARGET_PIXELS / thr for r in rows], [r["flip"] for r in rows], "o-",
                  label=it, ms=4)
    ax.axvline(FRAME_MS, color="k", lw=1)
    ax.text(FRAME_MS, ax.get_ylim()[1], " 16.7 ms", va="top", ha="left", fontsize=8)
    for t in st["thresholds"]:
        ax.axhline(t, color="0.6", lw=0.8, ls="--")
    where = "CPU" if st.get("device", "cpu") == "cpu" else "GPU"
    ax.set_xlabel(f"estimated frame time at 1920x1080 on this machine's {where} (ms)")
    ax.set_ylabel("mean FLIP")
    ax.set_title(f"{os.path.basename(res['scene'])}: mean FLIP vs frame time ({where})", fontsize=10)
    written += _save_plot(plt, fig, ax, out, "flip_vs_frame_time")
    return written


def _passes(n: int) -> str:
    return f"{n} pass" if n == 1 else f"{n} passes"


def _throughput_method(st: dict, w: int, h: int) -> str:
    tw, th = st["throughput_size"]
    if st["throughput_at"] == "1080p":
        return (f"Throughput was measured at {tw}x{th} ({tw * th} pixels: the scene's aspect at 1920x1080's pixel "
                f"count) with renders of {_passes(st['throughput_spp'])}, not scaled from the small size: a GPU needs "
                "about a million paths in flight to be busy, so its throughput grows with the resolution.")
    return (f"Throughput (samples per second) is measured at that size and scaled to 1920x1080 ({TARGET_PIXELS} "
            "pixels) by pixel count, i.e. the cost of a frame is taken as proportional to its pixels (the photon "
            "integrators trace one photon path per pixel per pass by default, so their cost scales likewise); "
            "per-render fixed costs at the small size make the throughput, and so the frame times, slightly "
            "pessimistic. (`--throughput-at 1080p` measures at 1080p instead.)")


def write_report(res: dict, out: Union[str, os.PathLike]) -> str:
    """Writes report.md, the plots (PNG and SVG) and results.json for a realtime() result into `out`;
    returns the report's path."""
    out = os.fspath(out)
    os.makedirs(out, exist_ok=True)
    _plots(res, out)
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump(res, f, indent=1, default=str)
    st = res["settings"]
    w, h = st["size"]
    ref = res["reference"]
    curve_lines = ["| integrator | " + " | ".join(f"{s} spp" for s in st["levels"]) + " |",
                   "|---|" + "---:|" * len(st["levels"])]
    for it, rows in res["curves"].items():
        curve_lines.append(f"| {it} | " + " | ".join(f"{r['flip']:.4f}" for r in rows) + " |")
    tw, th = st["throughput_size"]
    at_target = st["throughput_at"] == "1080p"
    tp_lines = ["| integrator | samples/s at " + f"{tw}x{th}" + " | 1-spp frames/s at 1920x1080 |", "|---|---:|---:|"]
    for it, v in res["throughput"].items():
        tp_lines.append(f"| {it} | {_fmt_rate(v)} | {v / TARGET_PIXELS:.2f} |")
    md = f"""# Real-time noise study: `{os.path.basename(res['scene'])}`

{f"Command: `{res['command']}`  " if res.get('command') else ""}
Date: {res['date'][:16].replace('T', ' ')} UTC; commit {res['commit']}; machine: {res['machine']}.
Other work on the machine took {res['foreign_cores']:.2f} of {res['cores']} cores on average during the
measurements{" — **timings are noisy**" if res['foreign_cores'] > 0.1 else ""}.

**Device:** {res['device_note']}

## Result

Samples per pixel (passes, for the photon integrators) needed to bring the mean FLIP error below each
threshold, and what that costs for one 1920x1080 frame at the throughput measured here:

{format_table(res['table'])}

*Speed-up missing* = frame time / 16.7 ms (60 Hz); "none" means the frame time already fits.
Thresholds: {", ".join(f"{t:g}" for t in st['thresholds'])} (mean FLIP, {st['flip_mode'].upper()}; 0: identical to the
reference, 1: the largest difference FLIP measures).

![mean FLIP vs spp](flip_vs_spp.png)

![mean FLIP vs estimated frame time](flip_vs_frame_time.png)

(SVG versions: flip_vs_spp.svg, flip_vs_frame_time.svg.)

## Method

- **Size.** Rendered at {w}x{h} ({w * h} pixels) for the noise; spp needed is taken as measured there:
  per-pixel noise depends on the samples per pixel, not on the resolution. {_throughput_method(st, w, h)}
- **FLIP at the small size.** Mean FLIP ({st['flip_mode'].upper()}, `caustica.metrics.flip`) is evaluated on
  the small image at FLIP's default {st['flip_ppd']:.0f} pixels per degree: as if the small image were shown
  with the pixel density of the 1080p display, so that FLIP's spatial filters see the per-pixel noise at the
  same angular scale. Not modelled: at 1080p a pixel covers less of the scene, so edges and texture vary less
  within it; the small size therefore somewhat overestimates the spp needed.
- **Reference.** {ref['integrator']}, {ref['spp']} spp, seed {ref['seed']}, at {w}x{h}
  (rendered at commit {ref.get('commit')}, {ref.get('seconds', float('nan')):.0f} s){"; cached as `reference/" + os.path.basename(ref['path']) + "` with its JSON sidecar" if ref.get('path') else ""}.
  Its own noise is part of the FLIP measured at high spp.
- **Curves.** Each integrator at spp {", ".join(map(str, st['levels']))}, one render per seed (seeds
  1..{st['seeds']}), each spp its own render (the photon integrators' radius shrinks over the passes); sampler
  {st['sampler'] or "the scene's (default sobol)"}; mean FLIP averaged over the seeds.
- **spp needed.** The first measured spp at or below the threshold, interpolated log-log with the one before;
  "≤ 1": already at 1 spp; not reached by the cap ({st['max_spp']}): extrapolated along the log-log
  least-squares line of the last three points (marked), or "not reached" when that line is flatter than a
  slope of -0.1.
- **Throughput.** Camera samples (photon integrators: passes × pixels) per second of render time; {
  f"the best of {max(2, st['seeds'])} renders of {_passes(st['throughput_spp'])} at {tw}x{th}" if at_target else
  "the best over the seeds of the renders at the two largest spp"}.
- **Frame time** at 1920x1080 = spp needed × {TARGET_PIXELS} / throughput.

## Measurements

Mean FLIP by spp:

{chr(10).join(curve_lines)}

Throughput:

{chr(10).join(tp_lines)}

Raw data (FLIP per seed, relMSE, render seconds): `results.json`.
"""
    path = os.path.join(out, "report.md")
    with open(path, "w") as f:
        f.write(md)
    return path
