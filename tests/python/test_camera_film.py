"""Pixel filters and the thin-lens camera."""
import math

import numpy as np
import pytest

import caustica


def edge_scene(filter_name, aperture=0.0, focus=None):
    # A half-plane emitter x > 0 seen head-on from 100 units away; 8 pixels span x in [-4, 4],
    # so the edge falls on a pixel boundary and pixel centres sit at +-0.5, +-1.5, ... pixels
    # from it (perspective distortion across 4 units at distance 100 is below 1e-3 pixel).
    cam = {"position": [0, 0, 100], "target": [0, 0, 0], "up": [0, 1, 0], "fov_axis": "x",
           "fov": 2 * math.degrees(math.atan(4 / 100)), "width": 8, "height": 2}
    if aperture:
        cam["aperture_radius"] = aperture
        cam["focus_distance"] = focus
    return {
        "camera": cam, "filter": filter_name,
        "materials": {"black": {"type": "diffuse", "reflectance": 0.0}},
        "shapes": [{"type": "rectangle", "material": "black", "emission": 1.0,
                    "transform": {"scale": [50, 50, 1], "translate": [50, 0, 0]}}],
    }


def filter_cdf(name, d):
    """P(X <= d) for the x-marginal of the filter, normalised, with X the sample offset."""
    if name == "box":
        return float(np.clip(d + 0.5, 0, 1))
    if name == "tent":
        if d <= -1:
            return 0.0
        if d >= 1:
            return 1.0
        return 0.5 * (1 + d) ** 2 if d < 0 else 1 - 0.5 * (1 - d) ** 2
    # gaussian: f(x) = exp(-x^2/(2 s^2)) - exp(-r^2/(2 s^2)) on [-r, r], s = 0.5, r = 2
    s, r = 0.5, 2.0
    x = np.linspace(-r, r, 200001)
    f = np.exp(-x * x / (2 * s * s)) - math.exp(-r * r / (2 * s * s))
    c = np.cumsum(f)
    return float(np.interp(d, x, c / c[-1]))


@pytest.mark.parametrize("name", ["box", "tent", "gaussian"])
def test_filter_edge_profile(name):
    spp = 16384
    img = caustica.render(edge_scene(name), spp=spp, max_depth=1, sampler="independent", seed=11)
    row = img[:, :, 0].mean(axis=0)  # 2 rows, averaged
    for i in range(8):
        d = (i + 0.5) - 4.0  # pixel centre's signed distance to the edge, in pixels
        expected = filter_cdf(name, d)  # P(centre + X > 0) = P(X > -d) = F(d) by symmetry
        # A ratio estimator over 2 * spp samples: standard error <= sqrt(p (1-p) / n) * (weight
        # spread factor, < 1.5 for the Gaussian's weights in [0.83, 1]); 4 of those, plus a
        # 2e-3 allowance for the perspective distortion of the pixel grid across the image.
        n = 2 * spp
        se = 1.5 * math.sqrt(max(expected * (1 - expected), 1.0 / n) / n)
        assert abs(row[i] - expected) < 4 * se + 2e-3, (name, i, row[i], expected)


def test_thin_lens_focus():
    # Focused on the emitter's plane, the edge stays as sharp as the pinhole's. Focused at
    # 200, the rays through a lens of radius 4 spread over a disk of radius
    # 4 * (1 - 100/200) = 2 units = 2 pixels on the emitter's plane at 100.
    pin = caustica.render(edge_scene("box"), spp=1024, max_depth=1, seed=1)[:, :, 0].mean(axis=0)
    sharp = caustica.render(edge_scene("box", aperture=4.0, focus=100.0), spp=1024, max_depth=1, seed=2)[:, :, 0].mean(axis=0)
    blur = caustica.render(edge_scene("box", aperture=4.0, focus=200.0), spp=1024, max_depth=1, seed=3)[:, :, 0].mean(axis=0)
    # In focus: pixels one step from the edge are 0 and 1, exactly as with the pinhole.
    assert np.allclose(sharp, pin, atol=1e-6)
    # Out of focus: light spreads across the edge (the disk of confusion has a 2-pixel
    # radius), so the pixel just left of the edge receives a substantial share; the
    # fraction for a point 0.5 px inside a disk of radius 2 px is ~0.34.
    assert blur[3] > 0.2 and blur[4] < 0.8
    assert abs(blur.sum() - pin.sum()) < 0.1 * pin.sum()  # energy is redistributed, not lost


# ---------------------------------------------------------------------------
# Filters with parameters and with negative lobes (mitchell, catmullrom, lanczos), through every kind of
# estimator: the path tracer's ratio of weighted sums, the photon mappers' and bdpt's sums over passes, and
# light tracing's splats (each pixel's filter value h_j at the light vertex's raster point, negative in a
# negative lobe).

def f1(spec, x):
    """The filter along one axis, unnormalised (film/filter.h), for a scene-format filter spec."""
    if isinstance(spec, str):
        spec = {"type": spec}
    t = spec["type"]
    a = np.abs(x)
    if t == "box":
        r = spec.get("radius", 0.5)
        return np.where((x >= -r) & (x < r), 1.0, 0.0)
    if t == "tent":
        r = spec.get("radius", 1.0)
        return np.where(a < r, 1 - a / r, 0.0)
    if t == "gaussian":
        s = spec.get("stddev", 0.5)
        r = spec.get("radius", 4 * s)
        return np.where(a < r, np.maximum(0, np.exp(-x * x / (2 * s * s)) - math.exp(-r * r / (2 * s * s))), 0.0)
    if t in ("mitchell", "catmullrom"):
        B, C = (0.0, 0.5) if t == "catmullrom" else (spec.get("B", 1 / 3), spec.get("C", 1 / 3))
        r = spec.get("radius", 2.0)
        u = 2 * a / r
        inner = ((12 - 9 * B - 6 * C) * u ** 3 + (-18 + 12 * B + 6 * C) * u ** 2 + (6 - 2 * B)) / 6
        outer = ((-B - 6 * C) * u ** 3 + (6 * B + 30 * C) * u ** 2 + (-12 * B - 48 * C) * u + (8 * B + 24 * C)) / 6
        return np.where(u < 1, inner, np.where(u < 2, outer, 0.0))
    if t == "lanczos":
        tau = spec.get("lobes", 3.0)
        r = spec.get("radius", tau)
        return np.where(a < r, np.sinc(x) * np.sinc(x / tau), 0.0)
    raise ValueError(t)


def edge_fraction(spec, d):
    """The filtered image of a unit step at signed distance d (pixels) from the pixel centre: the integral of
    f1 up to d over its whole integral (below 0 or above 1 in a negative lobe: ringing)."""
    x = np.linspace(-17, 17, 680001)
    c = np.cumsum(f1(spec, x))
    return float(np.interp(d, x, c / c[-1]))


def lit_edge_scene(spec):
    # A white diffuse half-plane x > 0 lit head-on by a sun of irradiance pi (radiance 1), on black; the
    # camera as edge_scene's (8 x 2 pixels over x in [-4, 4] at distance 100).
    scene = edge_scene(spec)
    scene["materials"] = {"white": {"type": "diffuse", "reflectance": 1.0}}
    scene["shapes"] = [{"type": "rectangle", "material": "white",
                        "transform": {"scale": [50, 50, 1], "translate": [50, 0, 0]}}]
    scene["lights"] = [{"type": "directional", "direction": [0, 0, -1], "irradiance": math.pi}]
    return scene


NEGATIVE_LOBES = ["mitchell", "catmullrom", "lanczos", {"type": "lanczos", "lobes": 2, "radius": 4},
                  {"type": "mitchell", "B": 0.2, "C": 0.4, "radius": 3}]
WITH_PARAMETERS = [{"type": "tent", "radius": 2}, {"type": "gaussian", "stddev": 0.3},
                   {"type": "box", "radius": 1.5}]


@pytest.mark.parametrize("integrator", ["path", "light", "bdpt", "sppm"])
@pytest.mark.parametrize("spec", NEGATIVE_LOBES + WITH_PARAMETERS, ids=lambda s: s if isinstance(s, str) else
                         "-".join(f"{k}{v}" for k, v in s.items()))
def test_filter_edge_profile_all_estimators(spec, integrator):
    seeds, spp = 16, 1024
    rows = np.array([caustica.render(lit_edge_scene(spec), integrator=integrator, spp=spp, max_depth=2,
                                     sampler="independent", seed=100 + k)[:, :, 0].mean(axis=0)
                     for k in range(seeds)])
    mean, se = rows.mean(axis=0), rows.std(axis=0, ddof=1) / math.sqrt(seeds)
    for i in range(8):
        expected = edge_fraction(spec, (i + 0.5) - 4.0)
        # 16 independent renders: 4.5 standard errors of their mean (t with 15 dof: two-sided 4e-4 per
        # pixel), plus 2e-3 for the perspective distortion of the pixel grid across the image (edge_scene).
        assert abs(mean[i] - expected) < 4.5 * se[i] + 2e-3, (spec, integrator, i, mean[i], expected, se[i])
    # The ringing is there: the pixel just outside the edge is below 0 with every negative-lobe filter.
    if spec in NEGATIVE_LOBES:
        assert edge_fraction(spec, -1.5) < -2e-3 and mean[2] < 0.0


def test_filter_object_in_scene_and_api():
    s = caustica.load_scene(lit_edge_scene({"type": "mitchell", "B": 0, "C": 0.5}))
    assert s.filter == "mitchell"
    assert s.filter_parameters == {"radius": 2.0, "B": 0.0, "C": 0.5}
    s = caustica.load_scene(lit_edge_scene("box"), filter={"type": "lanczos", "lobes": 2})
    assert s.filter == "lanczos" and s.filter_parameters == {"radius": 2.0, "lobes": 2.0}
    with pytest.raises(caustica.InputError, match=r"/film/filter/stddev: expected a number"):
        bad = {k: v for k, v in lit_edge_scene("box").items() if k != "filter"}
        caustica.load_scene({**bad, "film": {"filter": {"type": "gaussian", "stddev": "wide"}}})
    with pytest.raises(caustica.InputError, match=r"filter: /: the lanczos filter's lobes must be in \[1, 16\]"):
        caustica.load_scene(lit_edge_scene("box"), filter={"type": "lanczos", "lobes": 0.5})
    with pytest.raises(caustica.InputError, match=r"filter: /B: unknown key \(allowed: type, radius, lobes\)"):
        caustica.load_scene(lit_edge_scene("box"), filter={"type": "lanczos", "B": 0.5})


@pytest.mark.parametrize("spec", ["lanczos", {"type": "mitchell", "B": 0.25, "C": 0.375, "radius": 2.5},
                                  {"type": "gaussian", "stddev": 0.25}])
def test_filter_export_round_trip(tmp_path, spec):
    import json
    import os
    import jsonschema
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    f = tmp_path / "s.json"
    f.write_text(json.dumps(lit_edge_scene(spec)))
    out = tmp_path / "e.json"
    caustica.export_scene(str(f), str(out))
    doc = json.loads(out.read_text())
    jsonschema.Draft202012Validator(json.load(open(os.path.join(root, "docs", "scene.schema.json")))).validate(doc)
    written = doc["film"]["filter"]
    assert written == spec if isinstance(spec, str) else written["type"] == spec["type"]
    assert np.array_equal(caustica.render(str(f), spp=8, seed=5), caustica.render(str(out), spp=8, seed=5))


CUDA, WHY = caustica.cuda_status()


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
@pytest.mark.parametrize("integrator", ["path", "light", "bdpt", "sppm"])
@pytest.mark.parametrize("spec", ["mitchell", "lanczos", {"type": "gaussian", "stddev": 0.3}],
                         ids=["mitchell", "lanczos", "gaussian-0.3"])
def test_cuda_filter_edge_profile(spec, integrator):
    """The filters on the GPU (the same filter.h through the wavefront drivers): the lit edge's profile against
    the analytic filtered step, as test_filter_edge_profile_all_estimators on the CPU."""
    seeds, spp = 16, 1024
    rows = np.array([caustica.render(lit_edge_scene(spec), integrator=integrator, spp=spp, max_depth=2,
                                     sampler="independent", seed=100 + k, device="cuda")[:, :, 0].mean(axis=0)
                     for k in range(seeds)])
    mean, se = rows.mean(axis=0), rows.std(axis=0, ddof=1) / math.sqrt(seeds)
    for i in range(8):
        expected = edge_fraction(spec, (i + 0.5) - 4.0)
        # As on the CPU: 4.5 standard errors of the mean of 16 renders, plus 2e-3 for the perspective.
        assert abs(mean[i] - expected) < 4.5 * se[i] + 2e-3, (spec, integrator, i, mean[i], expected, se[i])
