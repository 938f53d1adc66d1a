#!/usr/bin/env python3
"""The CUDA backend's figures (issue 7), measured in one run, and what each wavefront switch gains:

  path tracer   samples/s and rays/s (camera, bounce and shadow rays) at 1920x1080 on `cornell` and on a
                scene of at least a million triangles (a torus of TORUS_TRIANGLES written here as PLY, on a
                floor under an area light), max depth 8 (Mitsuba's count), for each switch setting:
                  default            compaction on, no sorting, jittered samples
                  no-compaction      finished paths stay in the queues
                  sort-materials     queues sorted by material before shading
                  no-jitter          pixel centres (the baseline of the cache)
                  cache-first-bounce no-jitter + the first pass's camera hits reused
  sppm          passes/s, photons/s, and the seconds per stage (visible points, photon tracing, hash-grid
                build, gather) at 1920x1080 visible points and PHOTONS photon paths per pass on `cornell` and
                `smallvcm-spheres`; the grid build time per million stored photons; also with stochastic
                hashing (Hachisuka & Jensen 2010).
  bdpt, vcm, upg  ms per pass, rays/s (camera, light, visibility and trial rays together) and ms per stage
                (light subpaths, grid, camera subpaths, accumulation) at 1920x1080 on
                `smallvcm-spheres`, one light subpath per pixel (wavefront_vcm.h).

Targets (issue 7, H100): >= 1e9 rays/s for the path tracer on cornell at 1080p; a complete SPPM pass
(1M photons, 1080p visible points) under 16.7 ms.

Usage:
  .venv/bin/python bench/bench_gpu.py                         # --device cuda, the issue's sizes
  .venv/bin/python bench/bench_gpu.py --device cpu --width 160 --height 90 --photons 20000 --spp 2 --no-results
                                                              # the same stages on the CPU wavefront (a check)
Each figure is the best of --repeats runs (default 3) after one warm-up render. Appends a block to
bench/RESULTS.md (machine = the device's name, commit, command) unless --no-results.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import struct
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
try:
    import caustica  # the installed package (or PYTHONPATH: the GPU bundle of scripts/gpu-bundle.sh)
except ImportError:
    sys.path.insert(0, os.path.join(ROOT, "python"))
    import caustica  # noqa: E402
from caustica._provenance import commit, machine  # noqa: E402

RESULTS = os.path.join(HERE, "RESULTS.md")

PATH_SETTINGS = {
    "default": {},
    "no-compaction": {"compaction": False},
    "sort-materials": {"sort_materials": True},
    "no-jitter": {"jitter": False},
    "cache-first-bounce": {"jitter": False, "cache_first_bounce": True},
}


def write_torus_ply(path: str, triangles: int) -> int:
    """A torus (major radius 1, minor 0.35) of at least `triangles` triangles as binary little-endian PLY.
    Returns the triangle count."""
    n = int(np.ceil(np.sqrt(triangles / 2.0)))
    nu, nv = 2 * n, max(3, n // 2)
    while 2 * nu * nv < triangles:
        nv += 1
    u = np.linspace(0, 2 * np.pi, nu, endpoint=False)
    v = np.linspace(0, 2 * np.pi, nv, endpoint=False)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    R, r = 1.0, 0.35
    pos = np.stack([(R + r * np.cos(vv)) * np.cos(uu), r * np.sin(vv), (R + r * np.cos(vv)) * np.sin(uu)], -1)
    pos = pos.reshape(-1, 3).astype("<f4")
    i = np.arange(nu)[:, None]
    j = np.arange(nv)[None, :]
    a = i * nv + j
    b = ((i + 1) % nu) * nv + j
    c = ((i + 1) % nu) * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    tris = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    with open(path, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\n"
                 f"element vertex {len(pos)}\nproperty float x\nproperty float y\nproperty float z\n"
                 f"element face {len(tris)}\nproperty list uchar int vertex_indices\nend_header\n").encode())
        f.write(pos.tobytes())
        rec = np.empty(len(tris), dtype=[("n", "u1"), ("i", "<i4", 3)])
        rec["n"] = 3
        rec["i"] = tris
        f.write(rec.tobytes())
    return len(tris)


def torus_scene(dir_: str, triangles: int) -> tuple[str, int]:
    ply = os.path.join(dir_, "torus.ply")
    count = write_torus_ply(ply, triangles)
    scene = {
        "name": f"torus-{count}",
        "camera": {"position": [0, 2.2, 3.2], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 45},
        "materials": {"white": {"type": "diffuse", "reflectance": 0.7},
                      "copper": {"type": "conductor", "eta": [0.2, 0.92, 1.1], "k": [3.9, 2.45, 2.14],
                                 "roughness": 0.2}},
        "shapes": [
            {"type": "rectangle", "material": "white",
             "transform": {"scale": 6, "rotate": {"axis": [1, 0, 0], "angle": -90}, "translate": [0, -0.36, 0]}},
            {"type": "mesh", "file": "torus.ply", "material": "copper"},
            {"type": "rectangle", "material": "white", "emission": [8, 8, 8],
             "transform": {"scale": 0.6, "rotate": {"axis": [1, 0, 0], "angle": 90}, "translate": [0, 2.5, 0]}},
        ],
    }
    path = os.path.join(dir_, "torus.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    return path, count


def best_of(repeats: int, fn):
    runs = [fn() for _ in range(repeats)]
    return min(runs, key=lambda r: r["seconds"])


def bench_path(scene, a, label: str) -> list[dict]:
    rows = []
    for name, sw in PATH_SETTINGS.items():
        kw = dict(integrator="path", spp=a.spp, seed=1, max_depth=8, device=a.device, **sw)
        if a.device == "cpu":
            kw["wavefront"] = True
        caustica.render_job(scene, **dict(kw, spp=1))  # warm-up (device memory, caches)
        st = best_of(a.repeats, lambda: caustica.render_job(scene, **kw).stats)
        rays = st["rays"] + st["shadow_rays"]
        rows.append({"scene": label, "setting": name, "spp": st["passes"], "seconds": st["seconds"],
                     "samples_per_s": st["samples"] / st["seconds"], "rays_per_s": rays / st["seconds"],
                     "bounce_rays_per_s": st["rays"] / st["seconds"], "device": st["device"]})
    return rows


def bench_sppm(scene, a, label: str) -> list[dict]:
    rows = []
    for stochastic in (False, True):
        kw = dict(integrator="sppm", spp=a.spp, seed=1, max_depth=8, photons=a.photons, device=a.device,
                  stochastic_hash=stochastic)
        if a.device == "cpu":
            kw["wavefront"] = True
        caustica.render_job(scene, **dict(kw, spp=1))
        st = best_of(a.repeats, lambda: caustica.render_job(scene, **kw).stats)
        stages = st["stage_seconds"]
        passes = st["passes"]
        rows.append({"scene": label, "stochastic_hash": stochastic, "passes": passes, "seconds": st["seconds"],
                     "ms_per_pass": 1e3 * st["seconds"] / passes, "photons_per_s": st["photons"] / st["seconds"],
                     "stored_photons_per_pass": st["stored_photons"] / passes,
                     "grid_ms_per_million": 1e3 * stages["grid"] / max(st["stored_photons"] / 1e6, 1e-12),
                     **{f"ms_{k}": 1e3 * v / passes for k, v in stages.items()}, "device": st["device"]})
    return rows


def bench_bidirectional(scene, a, label: str) -> list[dict]:
    rows = []
    for integrator in ("bdpt", "vcm", "upg"):
        kw = dict(integrator=integrator, spp=a.bidir_spp, seed=1, max_depth=8, device=a.device)
        if a.device == "cpu":
            kw["wavefront"] = True
        caustica.render_job(scene, **dict(kw, spp=1))
        st = best_of(a.repeats, lambda: caustica.render_job(scene, **kw).stats)
        rows.append({"scene": label, "integrator": integrator, "passes": st["passes"], "seconds": st["seconds"],
                     "ms_per_pass": 1e3 * st["seconds"] / st["passes"], "rays_per_s": st["rays"] / st["seconds"],
                     **{f"ms_{k}": 1e3 * v / st["passes"] for k, v in st["stage_seconds"].items()},
                     "device": st["device"]})
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--device", default="cuda", help="cuda (default), cuda:N, or cpu (the CPU wavefront)")
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--spp", type=int, default=16, help="passes per render (path: samples per pixel)")
    ap.add_argument("--photons", type=int, default=1_000_000, help="sppm: photon paths per pass")
    ap.add_argument("--bidir-spp", type=int, default=4, help="bdpt, vcm, upg: passes per render")
    ap.add_argument("--triangles", type=int, default=1_000_000, help="the torus scene's triangle count")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-results", action="store_true", help="do not append to bench/RESULTS.md")
    a = ap.parse_args()
    if a.device != "cpu":
        cuda, why = caustica.cuda_status()
        if not cuda:
            print(f"bench_gpu: no CUDA device ({why}); use --device cpu for the CPU wavefront", file=sys.stderr)
            return 2
    started = datetime.datetime.now(datetime.timezone.utc)
    with tempfile.TemporaryDirectory() as tmp:
        torus_path, tris = torus_scene(tmp, a.triangles)
        scenes = {"cornell": caustica.load_scene("cornell", width=a.width, height=a.height),
                  f"torus ({tris} triangles)": caustica.load_scene(torus_path, width=a.width, height=a.height)}
        path_rows = []
        for label, sc in scenes.items():
            path_rows += bench_path(sc, a, label)
        sppm_rows = []
        for name in ("cornell", "smallvcm-spheres"):
            sppm_rows += bench_sppm(caustica.load_scene(name, width=a.width, height=a.height), a, name)
        bidir_rows = bench_bidirectional(caustica.load_scene("smallvcm-spheres", width=a.width, height=a.height), a,
                                         "smallvcm-spheres")
    device = path_rows[0]["device"]
    print(f"# {device}, {a.width}x{a.height}")
    for r in path_rows:
        print(f"path  {r['scene']:28s} {r['setting']:19s} {r['samples_per_s'] / 1e6:9.2f} M samples/s "
              f"{r['rays_per_s'] / 1e6:10.1f} M rays/s  ({r['bounce_rays_per_s'] / 1e6:.1f} M camera+bounce)")
    for r in sppm_rows:
        print(f"sppm  {r['scene']:18s} stochastic={int(r['stochastic_hash'])} {r['ms_per_pass']:8.2f} ms/pass "
              f"{r['photons_per_s'] / 1e6:8.2f} M photons/s  stages ms: visible {r['ms_visible_points']:.2f}, "
              f"photons {r['ms_photons']:.2f}, grid {r['ms_grid']:.2f} ({r['grid_ms_per_million']:.2f} per M), "
              f"gather {r['ms_gather']:.2f}")
    for r in bidir_rows:
        print(f"{r['integrator']:5s} {r['scene']:18s} {r['ms_per_pass']:8.2f} ms/pass {r['rays_per_s'] / 1e6:10.1f} M rays/s"
              f"  stages ms: light {r['ms_light_subpaths']:.2f}, grid {r['ms_grid']:.2f}, camera "
              f"{r['ms_camera_subpaths']:.2f}, accumulate {r['ms_accumulate']:.2f}")
    if not a.no_results:
        cmd = "python bench/bench_gpu.py " + " ".join(sys.argv[1:])
        host = machine()
        lines = [f"\n## {started:%Y-%m-%d %H:%M} UTC, commit {commit(ROOT)}: wavefront figures on {device} "
                 f"(bench_gpu.py)\n",
                 f"\nDevice: {device}; host: {host}. Command: `{cmd}`. {a.width}x{a.height}, best of "
                 f"{a.repeats} after a warm-up.\n",
                 "\n| scene | setting | samples/s | rays/s (all) | camera+bounce rays/s |\n|---|---|---|---|---|\n"]
        for r in path_rows:
            lines.append(f"| {r['scene']} | {r['setting']} | {r['samples_per_s'] / 1e6:.2f} M | "
                         f"{r['rays_per_s'] / 1e6:.1f} M | {r['bounce_rays_per_s'] / 1e6:.1f} M |\n")
        lines.append("\n| sppm scene | stochastic hash | ms/pass | photons/s | visible ms | photons ms | grid ms "
                     "(per M stored) | gather ms |\n|---|---|---|---|---|---|---|---|\n")
        for r in sppm_rows:
            lines.append(f"| {r['scene']} | {'yes' if r['stochastic_hash'] else 'no'} | {r['ms_per_pass']:.2f} | "
                         f"{r['photons_per_s'] / 1e6:.2f} M | {r['ms_visible_points']:.2f} | {r['ms_photons']:.2f} | "
                         f"{r['ms_grid']:.2f} ({r['grid_ms_per_million']:.2f}) | {r['ms_gather']:.2f} |\n")
        lines.append("\n| bidirectional | scene | ms/pass | rays/s | light ms | grid ms | camera ms | accumulate ms |\n"
                     "|---|---|---|---|---|---|---|---|\n")
        for r in bidir_rows:
            lines.append(f"| {r['integrator']} | {r['scene']} | {r['ms_per_pass']:.2f} | {r['rays_per_s'] / 1e6:.1f} M | "
                         f"{r['ms_light_subpaths']:.2f} | {r['ms_grid']:.2f} | {r['ms_camera_subpaths']:.2f} | "
                         f"{r['ms_accumulate']:.2f} |\n")
        with open(RESULTS, "a") as f:
            f.writelines(lines)
        print(f"appended to {os.path.relpath(RESULTS, ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
