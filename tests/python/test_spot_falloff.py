"""A spot light's falloff between falloff_start and cutoff_angle (light/light.h, spot_falloff): pbrt-v4's smoothstep
in cos(angle) (JSON default) or Mitsuba 3's linear in the angle ("falloff": "linear_angle", what Mitsuba XML
spots get), against the analytic image of a diffuse floor under the spot: seen from above through pixel centres,
the path tracer's direct light is deterministic, rho / pi * I falloff(theta) cos^3(theta) / h^2 at the point
theta off the axis. bench/RESULTS.md ("spotlit") compares Mitsuba scenes with Mitsuba 3.9.1."""
import json
import math

import numpy as np
import pytest

import caustica

H, CUT, START, RHO, I = 2.0, 30.0, 10.0, 0.6, 5.0


def spot_scene(falloff):
    light = {"type": "spot", "position": [0, H, 0], "direction": [0, -1, 0], "intensity": I,
             "cutoff_angle": CUT, "falloff_start": START}
    if falloff:
        light["falloff"] = falloff
    return {"camera": {"type": "orthographic", "position": [0, 5, 0], "target": [0, 0, 0], "up": [0, 0, -1],
                       "view_size": 3.0, "fov_axis": "x", "width": 96, "height": 8},
            "materials": {"floor": {"type": "diffuse", "reflectance": RHO}},
            "shapes": [{"type": "rectangle", "material": "floor",
                        "transform": {"scale": 4, "rotate": {"axis": [1, 0, 0], "angle": -90}}}],
            "lights": [light]}


def expected(x, falloff):
    th = np.arctan(np.hypot(x, 0.5 / 32) / H)  # row 4's centre is half a pixel (1/32 unit) off the axis
    deg = np.degrees(th)
    if falloff == "linear_angle":
        f = np.clip((CUT - deg) / (CUT - START), 0, 1)
    else:
        t = np.clip((np.cos(th) - math.cos(math.radians(CUT))) /
                    (math.cos(math.radians(START)) - math.cos(math.radians(CUT))), 0, 1)
        f = t * t * (3 - 2 * t)
    return RHO / math.pi * I * f * np.cos(th) ** 3 / H ** 2


@pytest.mark.parametrize("falloff", [None, "smoothstep", "linear_angle"])
def test_floor_under_a_spot_matches_the_analytic_falloff(falloff):
    img = caustica.render(spot_scene(falloff), spp=1, seed=1, max_depth=2, jitter=False)
    row = np.asarray(img[4, :, 1], np.float64)
    x = (np.arange(96) + 0.5) / 96 * 3.0 - 1.5  # pixel centres across the 3-unit view
    want = expected(x, falloff or "smoothstep")
    # The shadow ray leaves from 1e-4 above the floor (geometry/ray.h, offset_ray_origin), which changes 1/r^2
    # by 2e-4 / h = 1e-4 of the value; 2e-4 of the peak holds that and float rounding (the two curves differ by
    # more than 0.05 of the peak in the band, far outside it).
    assert np.abs(row - want).max() < 2e-4 * want.max(), np.abs(row - want).max()
    other = expected(x, "smoothstep" if falloff == "linear_angle" else "linear_angle")
    assert np.abs(other - want).max() > 0.05 * want.max()  # the two curves are told apart


def test_export_keeps_the_falloff_and_bad_names_are_errors(tmp_path):
    f = tmp_path / "s.json"
    f.write_text(json.dumps(spot_scene("linear_angle")))
    out = tmp_path / "e.json"
    caustica.export_scene(str(f), str(out))
    assert json.loads(out.read_text())["lights"][0]["falloff"] == "linear_angle"
    f.write_text(json.dumps(spot_scene("cubic")))
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(str(f))
    assert str(e.value) == f"{f}: /lights/0/falloff: unknown falloff 'cubic' (allowed: smoothstep, linear_angle)"
