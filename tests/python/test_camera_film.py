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
