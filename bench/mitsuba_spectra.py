#!/usr/bin/env python3
"""caustica's reduction of Mitsuba XML spectra to linear sRGB against Mitsuba 3's own (docs/formats-mitsuba.md,
"Spectra"; scene/spectrum.h).

1. Random piecewise-linear spectra (2 to 12 pairs between 340 and 860 nm, values in [0, 3]) given as a diffuse
   reflectance, a conductor's eta and a point light's intensity: the colours caustica loads (read back through
   `caustica.export_scene`) against `mi.spectrum_list_to_srgb` with Mitsuba's flags for each use (bounded and
   D65; unbounded and D65; unbounded without D65). Prints the largest difference relative to the colour's
   largest channel.
2. Blackbody emitters, which Mitsuba's RGB variants refuse to render: caustica's colour of a `constant` emitter
   of `type="blackbody"` against Mitsuba's `scalar_spectral` rendering of the same emitter (the mean of a 4x4
   image over independent seeds, with its standard error), and as a control a spectrum of pairs, whose colour
   is Mitsuba's own RGB reduction: Mitsuba's spectral render differs from its RGB reduction by a few tenths of
   a percent, so the blackbodies can agree no closer.

usage: .venv/bin/python bench/mitsuba_spectra.py [--spectra 200] [--seeds 16] [--spp 4096] [--rows]
(needs Mitsuba 3 from PyPI: bench/install-mitsuba.sh)
"""
import argparse
import datetime
import json
import os
import sys
import tempfile
import warnings

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python"))
import caustica  # noqa: E402
from caustica import _provenance  # noqa: E402


def export(xml):
    with tempfile.TemporaryDirectory() as d:
        f, out = os.path.join(d, "s.xml"), os.path.join(d, "s.json")
        with open(f, "w") as fh:
            fh.write(xml)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            caustica.export_scene(f, out)
        with open(out) as fh:
            return json.load(fh)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spectra", type=int, default=200)
    ap.add_argument("--seeds", type=int, default=16)
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--rows", action="store_true", help="print bench/RESULTS.md rows")
    args = ap.parse_args()
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    mi.set_log_level(mi.LogLevel.Error)
    rng = np.random.default_rng(7)
    worst = {"reflectance": 0.0, "eta": 0.0, "intensity": 0.0}
    for _ in range(args.spectra):
        n = int(rng.integers(2, 13))
        wl = np.sort(rng.choice(np.arange(340, 861), n, replace=False)).astype(float)
        v = np.round(rng.uniform(0, 3, n), 4)
        pairs = ", ".join(f"{a:g}:{b:g}" for a, b in zip(wl, v))
        j = export(f"""<scene version="3.0.0">
  <bsdf type="diffuse" id="d"><spectrum name="reflectance" value="{pairs}"/></bsdf>
  <bsdf type="conductor" id="c"><spectrum name="eta" value="{pairs}"/><rgb name="k" value="1"/></bsdf>
  <shape type="sphere"><ref id="d"/></shape><shape type="sphere"><point name="center" x="3"/><ref id="c"/></shape>
  <emitter type="point"><spectrum name="intensity" value="{pairs}"/></emitter></scene>""")
        got = {"reflectance": j["materials"]["d"]["reflectance"], "eta": j["materials"]["c"]["eta"],
               "intensity": j["lights"][0]["intensity"]}
        flags = {"reflectance": (True, True), "eta": (False, True), "intensity": (False, False)}
        for k, (bounded, d65) in flags.items():
            want = np.array(list(mi.spectrum_list_to_srgb(list(wl), list(v), bounded, d65)), float)
            scale = max(want.max(), 1e-3)
            worst[k] = max(worst[k], float(np.abs(np.array(got[k], float) - want).max() / scale))
    print(f"{args.spectra} random spectra: largest abs(caustica - Mitsuba) / largest channel: "
          + ", ".join(f"{k} {w:.1e}" for k, w in worst.items()))

    mi.set_variant("scalar_spectral")
    bb = []
    # The last one is a control: a spectrum of pairs, which Mitsuba's RGB variants reduce as caustica does (part
    # 1); its spectral variant's render differs from that reduction by as much as for the blackbodies.
    props = [(f"blackbody {k:g} K", f'<spectrum name="radiance" type="blackbody"><float name="temperature" '
              f'value="{k:g}"/></spectrum>') for k in (2000.0, 3000.0, 6500.0)]
    props.append(("control 400:2, 500:0.5, 700:1.5", '<spectrum name="radiance" value="400:2, 500:0.5, 700:1.5"/>'))
    for label, prop in props:
        c = np.array(export(f'<scene version="3.0.0"><emitter type="constant">{prop}</emitter></scene>')
                     ["lights"][0]["radiance"], float)
        scene = mi.load_string(f"""<scene version="3.0.0"><integrator type="path"/>
  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/>
    <rfilter type="box"/></film><sampler type="independent"/></sensor>
  <emitter type="constant">{prop}</emitter></scene>""")
        means = np.array([np.asarray(mi.render(scene, spp=args.spp, seed=s), float).reshape(-1, 3).mean(0)
                          for s in range(args.seeds)])
        m, se = means.mean(0), means.std(0, ddof=1) / np.sqrt(args.seeds)
        z = np.abs(c - m) / se
        line = (f"{label}: caustica ({c[0]:.5g}, {c[1]:.5g}, {c[2]:.5g}); Mitsuba 3.9.1 scalar_spectral "
                f"({m[0]:.5g}, {m[1]:.5g}, {m[2]:.5g}) +- ({se[0]:.2g}, {se[1]:.2g}, {se[2]:.2g}) "
                f"[{args.seeds} seeds x {args.spp} spp x 16 pixels]; difference {z.max():.1f} standard errors, "
                f"{100 * (np.abs(c - m) / m).max():.2f}% at most")
        print(line)
        bb.append(line)
    if args.rows:
        date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
        commit, machine = _provenance.commit(ROOT), _provenance.machine()
        cmd = f"`bench/mitsuba_spectra.py --spectra {args.spectra} --seeds {args.seeds} --spp {args.spp}`"
        print(f"| {date} | {machine} | {commit} | {cmd} | {args.spectra} random spectra, largest abs(caustica - Mitsuba "
              f"3.9.1) / largest channel: " + ", ".join(f"{k} {w:.1e}" for k, w in worst.items()) + " |")
        for line in bb:
            print(f"| {date} | {machine} | {commit} | {cmd} | {line} |")


if __name__ == "__main__":
    main()
