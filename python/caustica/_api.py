"""The Python API over the native module."""
from __future__ import annotations

import json
import os
import time as _time
from dataclasses import dataclass, field
from typing import Any, Callable, Optional, Union

import numpy as np

from . import _native

__version__ = "0.1.0"
InputError = _native.InputError

SAMPLERS = ("sobol", "independent")
FILTERS = ("box", "tent", "gaussian")
ACCELS = ("embree", "bvh")


def builtin_scenes() -> list[tuple[str, str]]:
    """(name, description) of every built-in scene, the default first."""
    return list(_native.builtin_scenes())


def default_scene_name() -> str:
    return _native.default_scene_name()


def integrators() -> list[str]:
    return list(_native.integrator_names())


def load_scene(scene: Union[str, os.PathLike, dict, "_native.Scene"], width: Optional[int] = None,
               height: Optional[int] = None, filter: Optional[str] = None) -> "_native.Scene":
    """Loads a built-in scene by name, a scene file (.json), or a scene given as a dict
    in caustica's JSON format. Optionally overrides the resolution and pixel filter."""
    if isinstance(scene, _native.Scene):
        s = scene
    elif isinstance(scene, dict):
        s = _native.load_scene_json(json.dumps(scene), "<dict>")
    elif isinstance(scene, (str, os.PathLike)):
        s = _native.load_scene(os.fspath(scene))
    else:
        raise InputError(f"scene: expected a name, a path or a dict, got {type(scene).__name__}")
    if width is not None or height is not None:
        s.set_resolution(_positive_int("width", width if width is not None else s.width),
                         _positive_int("height", height if height is not None else s.height))
    if filter is not None:
        if filter not in FILTERS:
            raise InputError(f"unknown filter '{filter}' (allowed: {', '.join(FILTERS)})")
        s.set_filter(filter)
    return s


def _positive_int(name: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v <= 0:
        raise InputError(f"{name} must be a positive integer, got {v!r}")
    return int(v)


@dataclass
class RenderResult:
    image: np.ndarray
    stats: dict = field(default_factory=dict)
    interrupted: bool = False


def render_job(scene, integrator: str = "path", spp: Optional[int] = None, time: Optional[float] = None,
               seed: int = 0, threads: int = 0, max_depth: Optional[int] = None, rr_depth: int = 5,
               sampler: str = "sobol", accel: str = "embree",
               progress: Optional[Callable[[dict], Any]] = None, poll: float = 0.1,
               photons: Optional[int] = None, radius: Optional[float] = None, alpha: float = 0.7,
               pass_offset: int = 0, stochastic_hash: bool = False, k: int = 50,
               checkpoint: Optional[Callable[[np.ndarray], Any]] = None,
               checkpoint_interval: Optional[float] = None) -> RenderResult:
    """Renders and returns a RenderResult; Ctrl-C (KeyboardInterrupt) stops the render and
    returns what was accumulated so far with interrupted=True.

    Photon integrators (sppm, ppm, pppm): `spp` counts passes; `photons` photon paths per
    pass (default one per pixel); `radius` the initial gather radius (default automatic,
    reported in stats["radius"]); `alpha` the radius reduction; `pass_offset` (pppm) renders
    passes [pass_offset, pass_offset + spp), which can be averaged with other ranges.
    `k` (pm): photons per k-nearest density estimate (default 50).
    `checkpoint(image)` is called every `checkpoint_interval` seconds with the image so far."""
    scene = load_scene(scene)
    if integrator not in integrators():
        raise InputError(f"unknown integrator '{integrator}' (allowed: {', '.join(integrators())})")
    if sampler not in SAMPLERS:
        raise InputError(f"unknown sampler '{sampler}' (allowed: {', '.join(SAMPLERS)})")
    if accel not in ACCELS:
        raise InputError(f"unknown accelerator '{accel}' (allowed: {', '.join(ACCELS)})")
    spp_i = 0 if spp is None else _positive_int("spp", spp)
    if time is not None and (not isinstance(time, (int, float)) or not time > 0 or time != time):
        raise InputError(f"time must be a positive number of seconds, got {time!r}")
    if max_depth is None:
        md = -2
    elif max_depth == -1:
        md = -1
    else:
        md = _positive_int("max_depth", max_depth)
    if photons is not None:
        _positive_int("photons", photons)
    if radius is not None and (not isinstance(radius, (int, float)) or not radius > 0):
        raise InputError(f"radius must be a positive number, got {radius!r}")
    if not isinstance(alpha, (int, float)) or not 0 < alpha < 1:
        raise InputError(f"alpha must be in (0, 1), got {alpha!r}")
    for name, v in (("seed", seed), ("threads", threads), ("pass_offset", pass_offset)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
            raise InputError(f"{name} must be a non-negative integer, got {v!r}")
    job = _native.RenderJob(scene, integrator=integrator, spp=spp_i, time=float(time or 0.0), seed=int(seed),
                            threads=int(threads), max_depth=md, rr_depth=_positive_int("rr_depth", rr_depth),
                            sampler=sampler, accel=accel, photons=int(photons or 0), radius=float(radius or 0.0),
                            alpha=float(alpha), pass_offset=int(pass_offset), stochastic_hash=bool(stochastic_hash),
                            k=_positive_int("k", k))
    interrupted = False
    job.start()
    last_checkpoint = _time.monotonic()
    try:
        while not job.wait(poll):
            if progress is not None and progress(job.stats()) is False:
                job.cancel()
            if checkpoint is not None and checkpoint_interval and _time.monotonic() - last_checkpoint >= checkpoint_interval:
                if job.stats()["passes"] > 0:
                    checkpoint(job.image())
                last_checkpoint = _time.monotonic()
    except KeyboardInterrupt:
        interrupted = True
        job.cancel()
        while not job.wait(poll):
            pass
    stats = job.stats()
    if progress is not None and not interrupted:
        progress(stats)
    return RenderResult(image=job.image(), stats=stats, interrupted=interrupted)


def render(scene, integrator: str = "path", spp: Optional[int] = None, time: Optional[float] = None,
           seed: int = 0, threads: int = 0, max_depth: Optional[int] = None, rr_depth: int = 5,
           sampler: str = "sobol", accel: str = "embree",
           progress: Optional[Callable[[dict], Any]] = None, **photon_options) -> np.ndarray:
    """Renders `scene` (a name, a path, a dict or a loaded scene) and returns linear RGB
    radiance as a float32 NumPy array of shape (H, W, 3).

    spp: samples per pixel; time: seconds (render whole passes until spent); with neither,
    16 spp. progress(stats) is called about ten times a second with a dict of counters
    (passes, target_passes, samples, rays, shadow_rays, seconds); returning False stops
    the render early. The GIL is released while rendering. Ctrl-C raises KeyboardInterrupt
    after stopping the render. Photon integrators take photons=, radius=, alpha=,
    pass_offset=, stochastic_hash= (see render_job)."""
    r = render_job(scene, integrator, spp, time, seed, threads, max_depth, rr_depth, sampler, accel, progress,
                   **photon_options)
    if r.interrupted:
        raise KeyboardInterrupt
    return r.image


def write_image(path: Union[str, os.PathLike], image: np.ndarray, exposure: float = 0.0) -> None:
    """Writes (H, W, 3) linear RGB as .exr, .pfm or .png (sRGB, scaled by 2^exposure),
    atomically (a temporary file renamed into place)."""
    a = np.ascontiguousarray(image, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise InputError(f"write_image: expected an (H, W, 3) array, got shape {a.shape}")
    _native.write_image(os.fspath(path), a, float(exposure))


def read_image(path: Union[str, os.PathLike]) -> np.ndarray:
    """Reads an .exr or .pfm image as a float32 (H, W, 3) array."""
    return _native.read_image(os.fspath(path))
