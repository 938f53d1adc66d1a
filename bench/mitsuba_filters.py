#!/usr/bin/env python3
"""caustica's pixel filters against Mitsuba 3's rfilters, pixel by pixel, on the image of a step edge
(docs/integrators.md, "Pixel filters"; film/filter.h).

The scene (Mitsuba XML, loaded by both renderers): a head-on emitting half-plane x > 0 of radiance 1 on black,
seen from 100 units away by an 8 x 2 image whose pixels are one unit wide, so the edge falls on a pixel boundary
and the pixel centres sit 0.5, 1.5, 2.5, 3.5 pixels from it. Each pixel is the filtered step: the fraction of
the filter's integral beyond the edge (outside [0, 1] near the edge for filters with negative lobes). Mitsuba
splats every sample onto the pixels its filter covers (sample_border on, so pixels near the image border see
the samples beyond it) and normalises by the weights; caustica importance-samples the filter: two estimators
of the same image. Per filter: both renderers' rows (mean over seeds), the largest difference and the largest
difference in standard errors of the difference (from the seeds' spread), and the analytic value's largest
distance from caustica.

usage: .venv/bin/python bench/mitsuba_filters.py [--seeds 8] [--spp 4096] [--variant llvm_ad_rgb] [--rows]
(needs Mitsuba 3 from PyPI and LLVM for its llvm variants: bench/install-mitsuba.sh)
"""
import argparse
import datetime
import math
import os
import sys
import tempfile
import warnings

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python"))
sys.path.insert(0, os.path.join(ROOT, "tests", "python"))
import caustica  # noqa: E402
from caustica import _provenance  # noqa: E402
from test_camera_film import edge_fraction  # noqa: E402  (the analytic filtered step)

FILTERS = [  # (rfilter XML, the same filter as caustica's scene-format spec)
    ('<rfilter type="box"/>', "box"),
    ('<rfilter type="tent"><float name="radius" value="2"/></rfilter>', {"type": "tent", "radius": 2}),
    ('<rfilter type="gaussian"/>', "gaussian"),
    ('<rfilter type="gaussian"><float name="stddev" value="0.3"/></rfilter>', {"type": "gaussian", "stddev": 0.3}),
    ('<rfilter type="mitchell"/>', "mitchell"),
    ('<rfilter type="mitchell"><float name="B" value="0.2"/><float name="C" value="0.4"/></rfilter>',
     {"type": "mitchell", "B": 0.2, "C": 0.4}),
    ('<rfilter type="catmullrom"/>', "catmullrom"),
    ('<rfilter type="lanczos"/>', "lanczos"),
    ('<rfilter type="lanczos"><integer name="lobes" value="2"/></rfilter>', {"type": "lanczos", "lobes": 2}),
]


def scene_xml(rfilter, spp, seed):
    fov = 2 * math.degrees(math.atan(4 / 100))
    return f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="2"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="{fov}"/><string name="fov_axis" value="x"/>
    <transform name="to_world"><lookat origin="0 0 100" target="0 0 0" up="0 1 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="{spp}"/><integer name="seed" value="{seed}"/></sampler>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="2"/>
      <boolean name="sample_border" value="true"/>{rfilter}</film>
  </sensor>
  <bsdf type="diffuse" id="black"><rgb name="reflectance" value="0"/></bsdf>
  <shape type="rectangle"><ref id="black"/>
    <transform name="to_world"><scale x="50" y="50" z="1"/><translate x="50"/></transform>
    <emitter type="area"><rgb name="radiance" value="1"/></emitter>
  </shape>
</scene>
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--variant", default="llvm_ad_rgb",
                    help="Mitsuba variant (llvm_ad_rgb needs DRJIT_LIBLLVM_PATH, bench/install-mitsuba.sh; "
                         "scalar_rgb's film evaluates the filter from its 31-entry table, eval_discretized)")
    ap.add_argument("--rows", action="store_true", help="print bench/RESULTS.md rows")
    args = ap.parse_args()
    if "llvm" in args.variant and not os.environ.get("DRJIT_LIBLLVM_PATH"):
        for cand in ("/usr/lib/x86_64-linux-gnu/libLLVM-19.so", "/usr/lib/llvm-19/lib/libLLVM.so"):
            if os.path.exists(cand):
                os.environ["DRJIT_LIBLLVM_PATH"] = cand
                break
    import mitsuba as mi
    mi.set_variant(args.variant)
    lines = []
    with tempfile.TemporaryDirectory() as d:
        for xml_filter, spec in FILTERS:
            ours, theirs = [], []
            for k in range(args.seeds):
                f = os.path.join(d, f"s{k}.xml")
                with open(f, "w") as fh:
                    fh.write(scene_xml(xml_filter, args.spp, k))
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # sample_border: ignored by caustica (it always samples there)
                    ours.append(caustica.render(f, spp=args.spp, seed=k, sampler="independent")[:, :, 0].mean(axis=0))
                theirs.append(np.array(mi.render(mi.load_file(f), spp=args.spp, seed=k))[:, :, 0].mean(axis=0))
            a, b = np.array(ours), np.array(theirs)
            ma, mb = a.mean(axis=0), b.mean(axis=0)
            se = np.sqrt(a.var(axis=0, ddof=1) / len(a) + b.var(axis=0, ddof=1) / len(b))
            z = np.abs(ma - mb) / np.maximum(se, 1e-12)
            # Mitsuba's image runs right to left along x (its camera's +x is the image's left): the step rises
            # towards the left there; caustica loads the same XML, so both rows have the same orientation.
            exact = np.array([edge_fraction(spec, (i + 0.5) - 4.0) for i in range(8)])
            if ma[0] > ma[-1]:
                exact = exact[::-1]
            name = xml_filter.split('"')[1] + ("" if isinstance(spec, str) else
                                               " " + ", ".join(f"{k}={v}" for k, v in spec.items() if k != "type"))
            line = (f"{name} (Mitsuba {mi.__version__} {args.variant}): caustica {np.array2string(ma, precision=4, separator=' ')}, Mitsuba "
                    f"{np.array2string(mb, precision=4, separator=' ')}; largest difference "
                    f"{np.abs(ma - mb).max():.4f} = {z.max():.1f} standard errors; caustica to the analytic "
                    f"filtered step {np.abs(ma - exact).max():.4f}")
            print(line, flush=True)
            lines.append(line)
    if args.rows:
        date = datetime.date.today().isoformat()
        commit, machine = _provenance.commit(ROOT), _provenance.machine()
        cmd = f"`bench/mitsuba_filters.py --seeds {args.seeds} --spp {args.spp} --variant {args.variant}`"
        print("\n| date | machine | commit | command | figure |\n|---|---|---|---|---|")
        for line in lines:
            print(f"| {date} | {machine} | {commit} | {cmd} | {line} |")


if __name__ == "__main__":
    main()
