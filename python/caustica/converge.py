"""Convergence runs: error against wall-clock time for several integrators at equal time.

    import caustica
    from caustica.converge import make_reference
    make_reference("cornell", "ref.exr", time=600)                            # + ref.exr.json
    log = caustica.converge("cornell", integrators=("path", "sppm"), time=60,
                            reference="ref.exr", out_dir="conv")             # list of dicts / DataFrame

Each integrator renders alone for the same time budget. A polling thread (this one) takes
snapshots of the image at checkpoint times (geometric by default: 8 per decade from 0.5 s,
plus the final image); a snapshot is `RenderJob.snapshot()`, a copy of the image and its counters
taken under the film's mutex while the render goes on. Cheap metrics (mse, rmse, relmse, mape: one pass over the
pixels) are computed on the snapshot at once and printed as progress; expensive ones (ssim,
flip) are computed on the kept snapshots after that integrator's render has ended, so they
never compete with the render threads. bench/bench_converge_overhead.py measures what is
left (docs/convergence.md).

With out_dir, the run writes there: converge.jsonl (a header line, then one line per
checkpoint), <metric>.png/.svg (error against time, log-log), grid.png (equal-time crops
of each integrator's final image and its error map), <integrator>.exr and
<integrator>.<metric>.exr (final image and error map).
"""
from __future__ import annotations

import contextlib as _contextlib
import datetime as _dt
import json
import math
import operator
import os
import tempfile
import time as _time
import warnings as _warnings
from typing import Any, Callable, Iterable, Optional, Sequence, Union

import numpy as np

from . import _api, _native
from ._api import InputError

from . import metrics as _metrics

# Metrics cheap enough to evaluate on each snapshot while the render runs (one pass over
# the pixels); the others wait until the render has ended.
LIVE_METRICS = ("mse", "rmse", "relmse", "mape")
# Labels for the plots' y axes; SSIM is a similarity, so its error is plotted as 1 - SSIM.
LABELS = {"mse": "MSE", "rmse": "RMSE", "relmse": "relMSE", "mape": "MAPE", "ssim": "1 − SSIM", "flip": "FLIP",
          "flip-hdr": "HDR-FLIP"}
REFERENCE_SEED = 1_000_003  # make_reference's default seed: far from converge's (0), so the noise is independent
SNAPSHOT_MEMORY = 1 << 30    # snapshots beyond this many bytes (per integrator) go to a temporary directory
RENDER_OPTIONS = ("threads", "max_depth", "rr_depth", "sampler", "accel", "photons", "radius", "alpha", "k",
                  "stochastic_hash", "photon_sampling", "restir_candidates", "restir_neighbors", "restir_radius",
                  "restir_history", "light_sampler", "volume_radius")


# ---------------------------------------------------------------------------------------------
# references

def sidecar_path(path: Union[str, os.PathLike]) -> str:
    """The JSON metadata file kept beside a reference image: REF.exr -> REF.exr.json."""
    return os.fspath(path) + ".json"


def load_reference(path: Union[str, os.PathLike]) -> tuple[np.ndarray, Optional[dict]]:
    """Reads a reference image (.exr or .pfm) and its sidecar metadata (None when there is none)."""
    p = os.fspath(path)
    if not os.path.isfile(p):
        raise InputError(f"reference '{p}' does not exist (render one with --make-reference / make_reference)")
    try:
        img = np.ascontiguousarray(_metrics.read(p), dtype=np.float32)
    except InputError:
        raise
    except Exception as e:  # noqa: BLE001 - a file that is not an image
        raise InputError(f"reference '{p}': cannot read it: {e}") from None
    if img.ndim != 3 or img.shape[2] != 3:
        raise InputError(f"reference '{p}': expected an RGB image, got shape {img.shape}")
    meta = None
    side = sidecar_path(p)
    if os.path.isfile(side):
        try:
            with open(side) as f:
                meta = json.load(f)
        except (OSError, ValueError) as e:
            raise InputError(f"reference metadata '{side}': {e}") from None
    return img, meta


def _scene_label(scene) -> str:
    if isinstance(scene, (str, os.PathLike)):
        return os.fspath(scene)
    if isinstance(scene, dict):
        return "<dict>"
    return getattr(scene, "name", "<scene>")


def _utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def make_reference(scene, path: Union[str, os.PathLike], integrator: str = "path", time: Optional[float] = None,
                   spp: Optional[int] = None, seed: int = REFERENCE_SEED, width: Optional[int] = None,
                   height: Optional[int] = None, camera: Optional[str] = None, params: Optional[dict] = None,
                   variant: Optional[str] = None, region: Optional[Sequence[int]] = None,
                   progress: Optional[Callable[[dict], Any]] = None, **render_options) -> dict:
    """Renders a reference image of `scene` to `path` (.exr or .pfm) for `time` seconds or `spp`
    samples (passes), and writes its metadata beside it (path + ".json": integrator, spp,
    samples, seed, seconds, scene, size, options, caustica version, date). Returns the metadata.

    region=(x, y, w, h): only those pixels of the film are rendered (a w x h reference of that part, all the
    time spent on it; the metadata keeps the region and the film's size, and converge renders the same part).

    The default seed differs from converge's, so the reference's noise is independent of the
    runs measured against it. A loaded Scene passed in gets its own size and crop back afterwards."""
    out = os.fspath(path)
    if os.path.splitext(out)[1].lower() not in (".exr", ".pfm"):
        raise InputError(f"cannot write reference '{out}': expected a .exr or .pfm file")
    d = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(d):
        raise InputError(f"cannot write reference '{out}': directory '{d}' does not exist")
    if time is None and spp is None:
        raise InputError("make_reference: give a time budget (seconds) or spp")
    _check_options(render_options)
    region = _region(region)
    with _framed(scene, width, height, camera, params, variant, region) as s:
        film = list(s.film_size)
        res = _api.render_job(s, integrator=integrator, spp=spp, time=time, seed=seed, progress=progress,
                              **render_options)
        width, height = s.width, s.height
    if res.interrupted:
        raise KeyboardInterrupt
    _api.write_image(out, res.image)
    st = res.stats
    meta = dict(integrator=st["integrator"], spp=int(st["passes"]), samples=int(st["samples"]), seed=int(seed),
                seconds=round(float(st["seconds"]), 3), time_budget=time, spp_budget=spp,
                scene=_scene_label(scene), width=width, height=height,
                options={k: v for k, v in render_options.items() if v is not None},
                caustica_version=_api.__version__, date=_utc_now())
    if region is not None:
        meta["region"], meta["film_size"] = list(region), film
    if st.get("photons"):
        meta["photons"] = int(st["photons"])
        meta["radius"] = float(st["radius"])
    tmp = sidecar_path(out) + ".tmp"
    with open(tmp, "w") as f:
        json.dump(meta, f, indent=2)
        f.write("\n")
    os.replace(tmp, sidecar_path(out))
    return meta


# ---------------------------------------------------------------------------------------------
# checkpoints and options

def checkpoint_times(time: float, checkpoints=None, start: float = 0.5) -> list[float]:
    """Checkpoint times in seconds, below `time` (the final image is always a checkpoint too).
    checkpoints: None (8 per decade from `start`), an int (that many per decade), or seconds."""
    if checkpoints is None or (isinstance(checkpoints, (int, np.integer)) and not isinstance(checkpoints, bool)):
        per_decade = 8 if checkpoints is None else int(checkpoints)
        if per_decade <= 0:
            raise InputError(f"checkpoints: expected a positive number per decade, got {checkpoints!r}")
        out, k = [], 0
        while True:
            t = start * 10 ** (k / per_decade)
            if t >= time * (1 - 1e-9):
                return out
            out.append(round(t, 4))
            k += 1
    try:
        ts = sorted(float(t) for t in checkpoints)
    except (TypeError, ValueError):
        raise InputError(f"checkpoints: expected None, a count per decade or a list of seconds, got {checkpoints!r}")
    if any(not (t > 0) or not math.isfinite(t) for t in ts):
        raise InputError(f"checkpoints: expected positive seconds, got {checkpoints!r}")
    return [t for t in ts if t < time]


def _check_options(opts: dict) -> None:
    unknown = sorted(set(opts) - set(RENDER_OPTIONS))
    if unknown:
        raise InputError(f"unknown render option(s) {', '.join(unknown)} (allowed: {', '.join(RENDER_OPTIONS)})")


def _job(scene, integrator: str, time: float, seed: int, opts: dict) -> "_native.RenderJob":
    """A RenderJob built the way caustica.render_job builds one (same defaults and checks)."""
    integrator, variant = _api.split_integrator_variant(integrator)
    opts = {**opts, **variant}
    o = _api.resolve_options(scene, integrator, None, time, opts.get("rr_depth"), opts.get("sampler"),
                             opts.get("photons"), opts.get("radius"), opts.get("alpha"), opts.get("k"),
                             opts.get("photon_sampling"),
                             opts.get("light_sampler") if integrator in _api.LIGHT_SAMPLER_INTEGRATORS else None)  # the others ignore it
    if o["sampler"] not in _api.SAMPLERS:
        raise InputError(f"unknown sampler '{o['sampler']}' (allowed: {', '.join(_api.SAMPLERS)})")
    accel = opts.get("accel") or "auto"
    if accel not in _api.ACCELS:
        raise InputError(f"unknown accelerator '{accel}' (allowed: {', '.join(_api.ACCELS)})")
    md = opts.get("max_depth")
    md = -2 if md is None else (-1 if md == -1 else _api._positive_int("max_depth", md))
    if o["photons"] is not None:
        _api._positive_int("photons", o["photons"])
    r = o["radius"]
    if r is not None and (not isinstance(r, (int, float)) or not r > 0):
        raise InputError(f"radius must be a positive number, got {r!r}")
    if not isinstance(o["alpha"], (int, float)) or not 0 < o["alpha"] < 1:
        raise InputError(f"alpha must be in (0, 1), got {o['alpha']!r}")
    threads = opts.get("threads") or 0
    for name, v in (("seed", seed), ("threads", threads)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
            raise InputError(f"{name} must be a non-negative integer, got {v!r}")
    return _native.RenderJob(scene, integrator=integrator, spp=0, time=float(time), seed=int(seed),
                             threads=int(threads), max_depth=md, rr_depth=_api._positive_int("rr_depth", o["rr_depth"]),
                             sampler=o["sampler"], accel=accel, photons=int(o["photons"] or 0),
                             radius=float(r or 0.0), alpha=float(o["alpha"]),
                             stochastic_hash=bool(opts.get("stochastic_hash", False)),
                             photon_sampling=_api._photon_sampling(o["photon_sampling"]),
                             k=_api._positive_int("k", o["k"]),
                             light_sampler=_api._light_sampler(o["light_sampler"]),
                             volume_radius=float(opts.get("volume_radius") or 0.0),
                             **_api.restir_job_options(scene, integrator, *(
                                 opts.get(key) if integrator == "restir" else None  # the others ignore them
                                 for key in ("restir_candidates", "restir_neighbors", "restir_radius",
                                             "restir_history"))))


def _metric_names(metrics) -> list[str]:
    if isinstance(metrics, str):
        metrics = [m.strip() for m in metrics.split(",") if m.strip()]
    names = list(metrics)
    if not names:
        raise InputError("metrics: give at least one metric")
    for m in names:
        if m not in _metrics.METRICS:
            raise InputError(f"unknown metric '{m}' (allowed: {', '.join(_metrics.METRICS)})")
    return list(dict.fromkeys(names))


def _integrator_names(integrators) -> list[str]:
    if isinstance(integrators, str):
        integrators = [i.strip() for i in integrators.split(",") if i.strip()]
    names = list(dict.fromkeys(integrators))
    if not names:
        raise InputError("integrators: give at least one integrator")
    allowed = _api.integrators()
    for i in names:
        base, _ = _api.split_integrator_variant(i)
        if base not in allowed:
            raise InputError(f"unknown integrator '{i}' (allowed: {', '.join(allowed)}; variants: "
                             f"{', '.join(_api.variant_names())})")
    return names


class _Snapshots:
    """Checkpoint images of one integrator: in memory up to SNAPSHOT_MEMORY bytes, then as .npy files."""

    def __init__(self):
        self.items: list = []
        self.bytes = 0
        self.tmp: Optional[tempfile.TemporaryDirectory] = None

    def add(self, img: np.ndarray) -> None:
        if self.bytes + img.nbytes <= SNAPSHOT_MEMORY:
            self.items.append(img)
            self.bytes += img.nbytes
            return
        if self.tmp is None:
            self.tmp = tempfile.TemporaryDirectory(prefix="caustica-converge-")
        p = os.path.join(self.tmp.name, f"{len(self.items)}.npy")
        np.save(p, img)
        self.items.append(p)

    def __getitem__(self, i) -> np.ndarray:
        x = self.items[i]
        return np.load(x) if isinstance(x, str) else x

    def close(self):
        if self.tmp is not None:
            self.tmp.cleanup()


def _evaluate(img, ref, names) -> dict:
    vals = _metrics.evaluate(img, ref, metrics=tuple(names))
    return {m: float(vals[m]) for m in names}


def _error_value(metric: str, v: float) -> float:
    """What the plots show: an error that falls towards 0 (SSIM -> 1 - SSIM)."""
    return 1.0 - v if metric == "ssim" else v


# ---------------------------------------------------------------------------------------------
# the run

class ConvergenceLog(list):
    """The checkpoint records (dicts) of a convergence run; .header holds the run's header."""
    header: dict = {}


def converge(scene, integrators: Union[str, Sequence[str]] = ("path", "sppm"), time: float = 60,
             reference=None, metrics: Union[str, Sequence[str]] = ("relmse", "flip"), checkpoints=None,
             seed: int = 0, out_dir: Union[str, os.PathLike, None] = None, width: Optional[int] = None,
             height: Optional[int] = None, camera: Optional[str] = None, params: Optional[dict] = None,
             variant: Optional[str] = None, crop: Optional[Sequence[int]] = None,
             progress: Optional[Callable[[dict], Any]] = None, as_frame: Optional[bool] = None,
             region: Optional[Sequence[int]] = None, **render_options):
    """Renders `scene` with each integrator for `time` seconds of wall clock and measures the
    error against `reference` (a path to an .exr/.pfm, with its .json sidecar when present,
    or an (H, W, 3) array) at checkpoint times (see checkpoint_times; the final image is the
    last checkpoint).

    Returns one record per checkpoint: integrator, elapsed_s (render seconds at the last
    completed pass of the snapshot), wall_s (seconds since start when it was taken), passes,
    samples, photons, final, and each metric; the final record also has measure_cpu_s, the CPU
    seconds this thread spent on snapshots and live metrics while the render ran. A pandas DataFrame (header in .attrs["header"])
    when pandas is installed and as_frame is not False, else a ConvergenceLog (a list with
    .header). render_options: threads, max_depth, rr_depth, sampler, accel, photons, radius,
    alpha, k, stochastic_hash, photon_sampling. progress(record) is called at each checkpoint.

    region=(x, y, w, h) renders and measures only those pixels of the film (default: the reference's region,
    make_reference(region=...), if it has one). The reference is then either that part (w x h) or the whole film,
    of which the part is taken. crop is the equal-time grid's window within the rendered image. A loaded Scene
    passed in is rendered at width/height and region for the run only: it gets its own size and crop back."""
    if not isinstance(time, (int, float)) or isinstance(time, bool) or not time > 0 or not math.isfinite(time):
        raise InputError(f"time must be a positive number of seconds, got {time!r}")
    names = _integrator_names(integrators)
    mnames = _metric_names(metrics)
    _check_options(render_options)
    times = checkpoint_times(float(time), checkpoints)
    if reference is None:
        raise InputError("converge: a reference image is needed (reference=PATH or an array)")
    if isinstance(reference, np.ndarray):
        ref, ref_meta, ref_path = np.ascontiguousarray(reference, dtype=np.float32), None, None
    else:
        ref_path = os.fspath(reference)
        ref, ref_meta = load_reference(ref_path)
    region = _region(region)
    ref_region = (ref_meta or {}).get("region")
    if region is None:
        region = _region(ref_region)
    elif ref_region is not None and list(region) != ref_region:
        raise InputError(f"region {region} differs from the reference's {tuple(ref_region)}")
    with _framed(scene, width, height, camera, params, variant, region) as s:
        return _converge(s, scene, names, mnames, times, time, ref, ref_meta, ref_path, region, crop, seed, out_dir,
                         progress, as_frame, render_options)


def _region(region) -> Optional[tuple]:
    """A region as (x, y, w, h) integers with a positive size (None stays None); where it lies in the film is
    checked when it is set (_framed)."""
    if region is None:
        return None
    try:
        x, y, w, h = (operator.index(v) for v in region)
    except (TypeError, ValueError):
        raise InputError(f"region: expected (x, y, width, height) in pixels of the film, got {region!r}") from None
    if w <= 0 or h <= 0:
        raise InputError(f"region: expected a positive width and height, got {(x, y, w, h)}")
    return x, y, w, h


@_contextlib.contextmanager
def _framed(scene, width, height, camera, params, variant, region):
    """The scene (loaded, or a loaded Scene as it is) at width x height and with its crop window set to `region`
    (from _region; None each: as it is) while the block runs; a loaded Scene passed in by the caller gets its own
    film size and window back afterwards."""
    s = _api.load_scene(scene, camera=camera, params=params, variant=variant)
    size, window = tuple(s.film_size), s.crop or (0, 0, 0, 0)
    _api.load_scene(s, width=width, height=height, crop=region)  # the region is checked against the film
    try:
        yield s
    finally:
        if (tuple(s.film_size), s.crop or (0, 0, 0, 0)) != (size, window):
            s.set_crop(0, 0, 0, 0)
            s.set_resolution(*size)
            s.set_crop(*window)


def _converge(s, scene, names, mnames, times, time, ref, ref_meta, ref_path, region, crop, seed, out_dir, progress,
              as_frame, render_options):
    if region is not None and ref.shape[:2] == tuple(s.film_size[::-1]) != (s.height, s.width):
        x, y, w, h = region  # a reference of the whole film: its part
        ref = np.ascontiguousarray(ref[y:y + h, x:x + w])
    if ref.shape[:2] != (s.height, s.width):
        raise InputError(f"reference{' ' + repr(ref_path) if ref_path else ''} is {ref.shape[1]}x{ref.shape[0]} "
                         f"but the scene renders {s.width}x{s.height} (set width/height to match)")
    if crop is not None:
        crop = _check_crop(crop, s.width, s.height)
    jobs = {i: _job(s, i, float(time), seed, render_options) for i in names}  # checks every option up front
    if out_dir is not None:
        out_dir = os.fspath(out_dir)
        os.makedirs(out_dir, exist_ok=True)
    live = [m for m in mnames if m in LIVE_METRICS]
    later = [m for m in mnames if m not in LIVE_METRICS]
    header = dict(type="header", scene=_scene_label(scene), width=s.width, height=s.height,
                  region=None if region is None else list(region), integrators=names, time=float(time),
                  metrics=mnames, live_metrics=live, checkpoints=times,
                  seed=int(seed), options={k: v for k, v in render_options.items() if v is not None},
                  reference=dict(path=ref_path, metadata=ref_meta), caustica_version=_api.__version__,
                  date=_utc_now())
    if ref_meta is not None and ref_meta.get("seed") == seed:
        _warnings.warn(f"the reference was rendered with seed {seed}, the same as this run's: their noise is "
                       "correlated and the error is underestimated", UserWarning, stacklevel=2)
    records: list[dict] = []
    finals: dict[str, np.ndarray] = {}
    for integ in names:
        recs, final = _run_one(jobs.pop(integ), integ, times, ref, live, later, progress)
        records.extend(recs)
        finals[integ] = final
    if out_dir is not None:
        _write_outputs(out_dir, header, records, finals, ref, mnames, crop)
    if as_frame is not False:
        try:
            import pandas as pd
        except ImportError:
            if as_frame:
                raise
        else:
            df = pd.DataFrame.from_records(records)
            df.attrs["header"] = header
            return df
    log = ConvergenceLog(records)
    log.header = header
    return log


def _run_one(job, integ, times, ref, live, later, progress):
    snaps = _Snapshots()
    recs: list[dict] = []

    def take(final: bool):
        # Waits for the pass in flight (the film's mutex), then copies the image and reads the counters
        # that match it (stats() read afterwards could already count tiles of the next pass).
        img, st = job.snapshot()
        t_wall = _time.monotonic() - t0
        same = bool(recs) and recs[-1]["passes"] == st["passes"]
        if not final and (st["passes"] == 0 or same):
            return
        if final and same:  # the final image is the last checkpoint's: keep it once, as final
            recs.pop()
            snaps.items.pop()
        rec = dict(integrator=integ, elapsed_s=round(float(st["seconds"]), 4), wall_s=round(t_wall, 4),
                   passes=int(st["passes"]), samples=int(st["samples"]), photons=int(st.get("photons") or 0),
                   final=final)
        if live:
            rec.update(_evaluate(img, ref, live))
        snaps.add(img)
        recs.append(rec)
        if progress is not None:
            progress(rec)

    try:
        t0 = _time.monotonic()
        cpu0 = _time.thread_time()
        job.start()
        k = 0
        try:
            while True:
                now = _time.monotonic() - t0
                wait = 0.1 if k >= len(times) else min(0.1, max(times[k] - now, 0.0))
                if job.wait(wait):
                    break
                now = _time.monotonic() - t0
                if k < len(times) and now >= times[k]:
                    take(False)
                    # the snapshot may have waited for a pass: skip checkpoints it has overtaken
                    now = _time.monotonic() - t0
                    while k < len(times) and times[k] <= now:
                        k += 1
        except KeyboardInterrupt:
            job.cancel()
            while not job.wait(0.1):
                pass
            raise
        cpu = _time.thread_time() - cpu0  # this thread's work during the render: copies, live metrics
        take(True)
        recs[-1]["measure_cpu_s"] = round(cpu, 4)
        final = snaps[len(recs) - 1]
        if later:  # the expensive metrics, now that the render threads are idle
            for i, rec in enumerate(recs):
                rec.update(_evaluate(snaps[i], ref, later))
        return recs, final
    finally:
        snaps.close()


# ---------------------------------------------------------------------------------------------
# outputs

def _check_crop(crop, w, h):
    try:
        x, y, cw, ch = (int(v) for v in crop)
    except (TypeError, ValueError):
        raise InputError(f"crop: expected (x, y, width, height), got {crop!r}") from None
    if x < 0 or y < 0 or cw <= 0 or ch <= 0 or x + cw > w or y + ch > h:
        raise InputError(f"crop {x},{y},{cw},{ch} does not fit in the {w}x{h} image")
    return x, y, cw, ch


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def write_log(path, header: dict, records: Iterable[dict]) -> None:
    """The JSON lines log: the header, then one line per checkpoint (type "checkpoint")."""
    tmp = os.fspath(path) + ".tmp"
    with open(tmp, "w") as f:
        f.write(json.dumps(header, default=_json_default) + "\n")
        for r in records:
            f.write(json.dumps(dict(type="checkpoint", **r), default=_json_default) + "\n")
    os.replace(tmp, path)


def read_log(path) -> tuple[dict, list[dict]]:
    """(header, checkpoint records) of a converge.jsonl log."""
    header, recs = {}, []
    with open(path) as f:
        for line in f:
            if not line.strip():
                continue
            d = json.loads(line)
            if d.get("type") == "header":
                header = d
            else:
                d.pop("type", None)
                recs.append(d)
    return header, recs


def _pyplot():
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    return plt


def plot_convergence(records: Sequence[dict], metric: str, path_stem: str, title: str = "") -> list[str]:
    """Error against time, log-log, one line per integrator, with a slope -1 guide; writes
    path_stem + ".png" and ".svg" (text kept as text) and returns the paths."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 4.2))
    first = None
    for integ in dict.fromkeys(r["integrator"] for r in records):
        pts = [(r["elapsed_s"], _error_value(metric, r[metric])) for r in records
               if r["integrator"] == integ and r.get(metric) is not None]
        pts = [(t, e) for t, e in pts if t > 0 and e > 0]
        if not pts:
            continue
        t, e = zip(*pts)
        ax.plot(t, e, marker="o", markersize=3.5, label=integ)
        if first is None:
            first = (t[0], e[0], t[-1])
    if first is not None and first[2] > first[0]:
        t0, e0, t1 = first
        ts = np.array([t0, t1])
        ax.plot(ts, e0 * t0 / ts, linestyle="--", color="0.6", linewidth=1, label="slope −1")
    ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import FuncFormatter
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    ax.xaxis.set_major_formatter(plain)
    ax.xaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}" if str(f"{v:g}")[0] in "25" else ""))
    ax.set_xlabel("time (s)")
    ax.set_ylabel(LABELS.get(metric, metric))
    if title:
        ax.set_title(title)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend()
    fig.tight_layout()
    out = [path_stem + ".png", path_stem + ".svg"]
    with plt.rc_context({"svg.fonttype": "none"}):
        fig.savefig(out[0], dpi=150)
        fig.savefig(out[1])
    plt.close(fig)
    return out


def plot_grid(finals: dict, ref: np.ndarray, records: Sequence[dict], metric: str, path: str,
              crop=None, metrics_shown: Sequence[str] = ()) -> str:
    """Equal-time grid: the reference crop, then per integrator its final image's crop and its
    `metric` error map (shared colour scale), labelled with time, passes and the final values of
    metrics_shown (default: metric)."""
    metrics_shown = list(metrics_shown) or [metric]
    plt = _pyplot()
    h, w = ref.shape[:2]
    x, y, cw, ch = crop if crop is not None else (0, 0, w, h)
    sl = (slice(y, y + ch), slice(x, x + cw))
    maps = {i: np.asarray(_metrics.error_map(img, ref, metric=metric))[sl] for i, img in finals.items()}
    vmax = max(float(np.percentile(m[np.isfinite(m)], 99)) if np.isfinite(m).any() else 0.0 for m in maps.values())
    vmax = vmax if vmax > 0 else 1.0
    n = len(finals)
    aspect = ch / cw
    fig, axes = plt.subplots(n + 1, 2, figsize=(6, 3 * aspect * (n + 1) + 0.4), squeeze=False)
    axes[0][0].imshow(_metrics.srgb_encode(ref[sl]), interpolation="nearest")
    axes[0][0].set_title("reference", fontsize=9)
    axes[0][1].axis("off")
    im = None
    for row, (integ, img) in enumerate(finals.items(), start=1):
        last = [r for r in records if r["integrator"] == integ][-1]
        label = f"{integ}: {last['elapsed_s']:.1f} s, {last['passes']} passes"
        axes[row][0].imshow(_metrics.srgb_encode(img[sl]), interpolation="nearest")
        axes[row][0].set_title(label, fontsize=9)
        im = axes[row][1].imshow(maps[integ], cmap="inferno", vmin=0, vmax=vmax, interpolation="nearest")
        vals = [f"{LABELS.get(m, m)} {last[m]:.4g}" for m in metrics_shown if last.get(m) is not None]
        axes[row][1].set_title("\n".join(vals) or f"{LABELS.get(metric, metric)} map", fontsize=8)
    for a in axes.ravel():
        a.set_xticks([])
        a.set_yticks([])
    if im is not None:
        fig.colorbar(im, ax=[axes[r][1] for r in range(1, n + 1)], shrink=0.8, label=f"{LABELS.get(metric, metric)} per pixel")
    fig.savefig(path, dpi=150, bbox_inches="tight")
    plt.close(fig)
    return path


def _write_outputs(out_dir, header, records, finals, ref, mnames, crop):
    write_log(os.path.join(out_dir, "converge.jsonl"), header, records)
    title = f"{header['scene']}, {header['width']}x{header['height']}"
    for m in mnames:
        plot_convergence(records, m, os.path.join(out_dir, m), title=title)
    for integ, img in finals.items():
        _api.write_image(os.path.join(out_dir, f"{integ}.exr"), img)
        for m in dict.fromkeys(m for m in mnames if m in _metrics.ERROR_MAPS):
            _metrics.write_error_map(os.path.join(out_dir, f"{integ}.{m}.exr"),
                                     _metrics.error_map(img, ref, metric=m))
    plot_grid(finals, ref, records, _map_metric(mnames), os.path.join(out_dir, "grid.png"), crop=crop,
              metrics_shown=mnames)


def _map_metric(mnames) -> str:
    """The error map the grid shows: the first requested metric that has one (rmse: mse's)."""
    for m in mnames:
        m = "mse" if m == "rmse" else m
        if m in _metrics.ERROR_MAPS:
            return m
    return "relmse"
