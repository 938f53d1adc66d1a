"""Mesh load benchmark: OBJ, PLY (binary) and GLB files of the same torus of a few million triangles.

Build the C++ part first:  cmake --build build/py --target caustica_bench_load   (after `make build`)
Run:                       .venv/bin/python bench/bench_load.py [--triangles 3000000] [--dir DIR] [--repeats 2]

Generates the three files with `caustica_bench_load generate`, then runs `caustica_bench_load load FILE` in a
fresh process per format and repeat (so each peak RSS is that format's alone) and prints Markdown rows for
bench/RESULTS.md: load_scene_desc time, Scene::build time (which includes the Embree build), Embree's BVH build
alone, and peak resident memory (ru_maxrss) after the load and after the build. Times: best of the repeats.
"""
import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "build", "py", "caustica_bench_load")


from caustica._provenance import commit as _provenance_commit, machine  # noqa: E402


def commit():
    return _provenance_commit(ROOT)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=float, default=3e6)
    ap.add_argument("--dir", default=None, help="where to write the files (default: a temporary folder)")
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    if not os.path.exists(BIN):
        sys.exit(f"{BIN} is missing: cmake --build build/py --target caustica_bench_load")
    tmp = None
    d = args.dir
    if d is None:
        tmp = tempfile.TemporaryDirectory(prefix="caustica_bench_load_")
        d = tmp.name
    os.makedirs(d, exist_ok=True)
    gen = json.loads(subprocess.run([BIN, "generate", d, str(int(args.triangles))], check=True,
                                    capture_output=True, text=True).stdout)
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    cmd = "bench/bench_load.py " + " ".join(sys.argv[1:])
    host, rev = machine(), commit()
    rows = []
    for ext in ("obj", "ply", "glb"):
        path = os.path.join(d, "mesh." + ext)
        size = os.path.getsize(path) / 2**20
        runs, err = [], ""
        for _ in range(args.repeats):
            r = subprocess.run([BIN, "load", path], capture_output=True, text=True)
            if r.returncode != 0:
                err = r.stderr.strip().splitlines()[-1] if r.stderr.strip() else f"exit {r.returncode}"
                break
            runs.append(json.loads(r.stdout))
        if not runs:
            rows.append(f"| {date} | {host} | {rev} | `{cmd}` | {ext.upper()} | {size:.0f} | failed: {err} | | | | | |")
            continue
        best = lambda k: min(x[k] for x in runs)
        r0 = runs[0]
        rows.append(f"| {date} | {host} | {rev} | `{cmd}` | {ext.upper()} | {size:.0f} | {r0['triangles']:,} | "
                    f"{best('load_s'):.2f} | {best('build_s'):.2f} | {best('embree_s'):.2f} | "
                    f"{max(x['peak_after_load_mib'] for x in runs):.0f} | {max(x['peak_after_build_mib'] for x in runs):.0f} |")
    print(f"Mesh: torus, {gen['vertices']:,} vertices (positions, normals, uvs), {gen['triangles']:,} triangles; "
          f"files written in {gen['seconds']:.1f} s.\n")
    print("| date | machine | commit | command | format | file MiB | triangles | load_scene_desc s | Scene::build s | "
          "Embree build s | peak RSS after load MiB | peak RSS after build MiB |")
    print("|---|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(r)
    if tmp:
        tmp.cleanup()


if __name__ == "__main__":
    main()
