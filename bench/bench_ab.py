#!/usr/bin/env python3
"""Two builds of caustica against each other: the same renders, alternating between the builds, one process each.

A change that should only make caustica faster (or that may cost time) is measured against the build before it:
snapshot the build before the change with --save, rebuild with the change, then time both. Every render runs in a
fresh Python process importing one build (the editable install's import hook is removed from that process, so the
folder given is the caustica it runs); A and B alternate, so that drifts of the machine's speed hit both alike.
Each process renders once to warm up (spp 1) and then the timed render; the time is stats["seconds"] (the passes,
not the scene load). Per case the script reports the median times, their ratio (A / B: above 1, B is faster) and
how far the two images are apart at the same seed (identical, or the relMSE between them and the largest
relative difference of a pixel).

Usage:
    .venv/bin/python bench/bench_ab.py --save /tmp/ab/old              # before the change: snapshot the build
    # ... change, `make build` ...
    .venv/bin/python bench/bench_ab.py --a /tmp/ab/old --b current     # about 5 minutes on 2 cores
    .venv/bin/python bench/bench_ab.py --a /tmp/ab/old --b current --runs 3 \\
        --case "cornell path 64" --case "tests/data/json/many-lights.json restir 8 width=128 height=96"

With --instructions the builds are compared by the instructions they execute instead (deterministic where wall
times on a shared machine vary by 10%): each case runs once per build under valgrind's callgrind, on one thread,
without the warm-up render, and once more without the render at all; the difference is the render's count.
Needs valgrind; about 50 times slower than the render itself, so use a few spp.

    .venv/bin/python bench/bench_ab.py --a /tmp/ab/old --b current --instructions \
        --case "bench/scenes/mr_spheres.json path 16" --case "bench/scenes/mr_spheres.json bdpt 4"

A case is "SCENE INTEGRATOR SPP [KEY=VALUE ...]": a built-in scene or a scene file, and render_job keyword
arguments (width and height are given to load_scene; numbers are read as numbers). Printed and appended to
bench/RESULTS.md unless --no-append.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402

from bench_cornell_depth import ROOT, append_block  # noqa: E402

MANY_LIGHTS = os.path.join(ROOT, "tests", "data", "json", "many-lights.json")
DEFAULT_CASES = [
    f"{MANY_LIGHTS} path 16 width=256 height=192",
    f"{MANY_LIGHTS} restir 8 width=256 height=192",
    "cornell path 64",
    "smallvcm-spheres vcm 8",
    "cornell sppm 16",
]

# The child: imports the build in argv[1] (without the editable install's redirecting import hook), renders the
# case once to warm up and once timed, writes the image to argv[3] and prints the timing as JSON.
CHILD = r"""
import json, sys
sys.meta_path = [f for f in sys.meta_path if "editable" not in type(f).__module__.lower()]
sys.path.insert(0, sys.argv[1])
import numpy as np
import caustica
case = json.loads(sys.argv[2])
scene = caustica.load_scene(case["scene"], **case["size"])
if not case.get("render", True):
    print(json.dumps({}))
    sys.exit(0)
if case.get("warmup", True):
    caustica.render_job(scene, integrator=case["integrator"], spp=1, seed=case["seed"], **case["kwargs"])
r = caustica.render_job(scene, integrator=case["integrator"], spp=case["spp"], seed=case["seed"], **case["kwargs"])
np.save(sys.argv[3], r.image)
print(json.dumps({"seconds": r.stats["seconds"], "passes": r.stats["passes"], "file": caustica.__file__,
                  "native": caustica._native.__file__}))
"""


def _editable_build() -> str:
    """A folder holding the editable install's caustica (python/caustica and the built _native module)."""
    out = tempfile.mkdtemp(prefix="caustica-current-")
    save(out)
    return out


def save(dest: str) -> None:
    """Copies the caustica this interpreter imports (its Python files and _native module) into dest/caustica,
    with dest/BUILD.json naming the commit."""
    import caustica
    from caustica._provenance import commit
    pkg = os.path.dirname(caustica.__file__)
    target = os.path.join(dest, "caustica")
    if os.path.exists(target):
        shutil.rmtree(target)
    shutil.copytree(pkg, target, ignore=shutil.ignore_patterns("__pycache__", "_native*.so"))
    shutil.copy2(caustica._native.__file__, target)
    with open(os.path.join(dest, "BUILD.json"), "w") as f:
        json.dump({"commit": commit(ROOT), "saved": _dt.datetime.now(_dt.timezone.utc).isoformat()}, f)


def _label(path: str) -> str:
    try:
        with open(os.path.join(path, "BUILD.json")) as f:
            return json.load(f)["commit"]
    except (OSError, ValueError, KeyError):
        return os.path.basename(path.rstrip("/"))


def parse_case(text: str, seed: int) -> dict:
    parts = text.split()
    if len(parts) < 3:
        raise SystemExit(f"--case expects 'SCENE INTEGRATOR SPP [KEY=VALUE ...]', got '{text}'")
    kwargs, size = {}, {}
    for kv in parts[3:]:
        k, eq, v = kv.partition("=")
        if not eq:
            raise SystemExit(f"--case: expected KEY=VALUE, got '{kv}' in '{text}'")
        for conv in (int, float):
            try:
                v = conv(v)
                break
            except ValueError:
                pass
        (size if k in ("width", "height") else kwargs)[k] = v
    return {"scene": parts[0], "integrator": parts[1], "spp": int(parts[2]), "seed": seed, "kwargs": kwargs,
            "size": size}


def run_once(build: str, case: dict, image: str) -> dict:
    p = subprocess.run([sys.executable, "-c", CHILD, build, json.dumps(case), image], capture_output=True,
                       text=True, cwd=ROOT)
    if p.returncode != 0:
        raise SystemExit(f"render failed with build {build}: {p.stderr.strip().splitlines()[-1:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def count_instructions(build: str, case: dict, image: str) -> int:
    """Instructions (callgrind's Ir) of the case's render in build: one run with the render, one without."""
    counts = []
    for render in (True, False):
        c = {**case, "warmup": False, "render": render, "kwargs": {**case["kwargs"], "threads": 1}}
        p = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", sys.executable, "-c",
                            CHILD, build, json.dumps(c), image], capture_output=True, text=True, cwd=ROOT)
        found = [ln for ln in p.stderr.splitlines() if "Collected :" in ln]
        if p.returncode != 0 or not found:
            raise SystemExit(f"callgrind run failed with build {build}: {p.stderr.strip().splitlines()[-1:]}")
        counts.append(int(found[-1].split(":")[-1].strip()))
    return counts[0] - counts[1]


def compare(a: np.ndarray, b: np.ndarray) -> str:
    if np.array_equal(a, b):
        return "identical"
    rel = np.abs(a - b) / (np.abs(a) + 1e-2)
    relmse = float(np.mean((a - b) ** 2 / (a * a + 1e-2)))
    return f"relMSE {relmse:.2g}, max rel. {float(rel.max()):.2g}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--save", metavar="DIR", help="snapshot the build this interpreter imports into DIR and stop")
    ap.add_argument("--a", metavar="DIR", help="build A (a folder from --save)")
    ap.add_argument("--b", metavar="DIR", default="current",
                    help="build B (a folder from --save, or 'current': the editable install; default)")
    ap.add_argument("--case", action="append", default=None, metavar="'SCENE INTEGRATOR SPP [KEY=VALUE ...]'")
    ap.add_argument("--runs", type=int, default=5, help="timed processes per build and case (default 5)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-append", action="store_true")
    ap.add_argument("--instructions", action="store_true",
                    help="compare instruction counts under callgrind (one thread, one run each) instead of times")
    a = ap.parse_args()
    if a.save:
        save(a.save)
        print(f"saved the build ({_label(a.save)}) to {a.save}")
        return 0
    if not a.a:
        ap.error("--a DIR is needed (or --save DIR)")
    builds = {"A": a.a, "B": _editable_build() if a.b == "current" else a.b}
    labels = {k: _label(v) for k, v in builds.items()}
    started = _dt.datetime.now(_dt.timezone.utc)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for text in a.case or DEFAULT_CASES:
            case = parse_case(text, a.seed)
            if a.instructions:
                images = {}
                ir = {}
                for k in ("A", "B"):
                    path = os.path.join(tmp, f"{k}.npy")
                    ir[k] = count_instructions(builds[k], case, path)
                    images[k] = np.load(path)
                diff = compare(images["A"], images["B"])
                name = os.path.relpath(case["scene"], ROOT) if os.path.exists(case["scene"]) else case["scene"]
                opts = " ".join(f"{k}={v}" for k, v in {**case["size"], **case["kwargs"]}.items())
                print(f"{name} {case['integrator']} {case['spp']} spp {opts}: A {ir['A'] / 1e9:.4f} G, "
                      f"B {ir['B'] / 1e9:.4f} G instructions, B/A {ir['B'] / ir['A']:.4f}; images {diff}", flush=True)
                rows.append([f"{name} {opts}".strip(), case["integrator"], str(case["spp"]), f"{ir['A'] / 1e9:.4f}",
                             f"{ir['B'] / 1e9:.4f}", f"{ir['B'] / ir['A']:.4f}", diff])
                continue
            times = {"A": [], "B": []}
            images = {}
            for i in range(a.runs):
                for k in ("A", "B"):
                    path = os.path.join(tmp, f"{k}.npy")
                    times[k].append(run_once(builds[k], case, path)["seconds"])
                    if i == 0:
                        images[k] = np.load(path)
            med = {k: statistics.median(v) for k, v in times.items()}
            ratio = med["A"] / med["B"]
            diff = compare(images["A"], images["B"])
            name = os.path.relpath(case["scene"], ROOT) if os.path.exists(case["scene"]) else case["scene"]
            opts = " ".join(f"{k}={v}" for k, v in {**case["size"], **case["kwargs"]}.items())
            spread = " ".join(f"{t:.3f}" for t in sorted(times["A"])) + " / " + \
                " ".join(f"{t:.3f}" for t in sorted(times["B"]))
            print(f"{name} {case['integrator']} {case['spp']} spp {opts}: A {med['A']:.3f} s, B {med['B']:.3f} s, "
                  f"A/B {ratio:.3f}; images {diff}; all runs {spread}", flush=True)
            rows.append([f"{name} {opts}".strip(), case["integrator"], str(case["spp"]), f"{med['A']:.3f}",
                         f"{med['B']:.3f}", f"{ratio:.3f}", diff, spread])
    if builds["B"] != a.b:
        shutil.rmtree(builds["B"], ignore_errors=True)
    if not a.no_append and a.instructions:
        append_block("bench_ab.py", started, labels["B"], f"instructions of build {labels['B']} (B) against "
                     f"{labels['A']} (A)",
                     f"Settings: --instructions: callgrind's instruction count of each render (one run with it less "
                     f"one without it), one thread, no warm-up; seed {a.seed}; B/A below 1: B executes fewer.",
                     ["scene", "integrator", "spp", "A (G instr.)", "B (G instr.)", "B/A", "images"], rows)
    elif not a.no_append:
        append_block("bench_ab.py", started, labels["B"], f"build {labels['B']} (B) against {labels['A']} (A)",
                     f"Settings: each case timed in {a.runs} fresh processes per build, A and B alternating, after "
                     f"one 1-spp warm-up render in each process; seed {a.seed}; all threads; times are "
                     "stats['seconds'] (the passes), medians; A/B above 1: B is faster. Images of the first run "
                     "compared (relMSE with 0.01 in the denominator).",
                     ["scene", "integrator", "spp", "A (s)", "B (s)", "A/B", "images", "all runs: A / B"], rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
