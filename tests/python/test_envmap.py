"""Environment maps end to end (docs/materials.md): a furnace inside a uniform map, the map's
orientation in a render, and the path tracer against SPPM (photons emitted from the map) under
a map with a bright sun."""
import json
import math
import warnings

import numpy as np
import pytest

import caustica

from conftest import mean_and_se


def scene(env, shapes, materials, camera, res=32):
    d = {"camera": dict(camera, width=res, height=res), "materials": materials, "shapes": shapes,
         "lights": [env]}
    return d


def render(d, base_dir, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return caustica.render(caustica.load_dict(d, base_dir=str(base_dir)), **kw)


def test_furnace_sphere_in_a_uniform_map(tmp_path):
    """A convex diffuse sphere of albedo 0.8 under a uniform map of radiance 0.5 x scale 2:
    the sphere is 0.8 everywhere, the background 1 (every bounce leaves to the sky)."""
    caustica.write_image(tmp_path / "grey.exr", np.full((8, 16, 3), 0.5, np.float32))
    d = scene({"type": "environment", "file": "grey.exr", "scale": 2},
              [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}],
              {"m": {"type": "diffuse", "reflectance": 0.8}},
              {"position": [0, 0, 4], "target": [0, 0, 0], "fov": 40})
    img = render(d, tmp_path, spp=16, seed=1)
    centre = img[12:20, 12:20].reshape(-1, 3)
    m, se = mean_and_se(centre[:, 0])
    assert abs(m - 0.8) < 4 * se + 1e-4, (m, se)  # 4 standard errors (pixels are independent)
    assert np.allclose(img[0, 0], 1.0, atol=1e-5)  # background: the map itself, exactly


def test_orientation_in_a_render(tmp_path):
    """A map whose left half (u < 0.5) is red and right half blue: looking along +z (the image
    centre, u = 0.5 is the boundary) ... so look along +x (u = 0.25: red) and -x (u = 0.75: blue)."""
    img = np.zeros((8, 16, 3), np.float32)
    img[:, :8] = (1, 0, 0)
    img[:, 8:] = (0, 0, 1)
    caustica.write_image(tmp_path / "halves.exr", img)
    floor = {"type": "rectangle", "material": "m", "transform": {"scale": 0.01, "translate": [0, -100, 0]}}
    for target, colour in (([1, 0, 0], 0), ([-1, 0, 0], 2)):
        d = scene({"type": "environment", "file": "halves.exr"}, [floor], {"m": {"type": "diffuse"}},
                  {"position": [0, 0, 0], "target": target, "fov": 10}, res=8)
        out = render(d, tmp_path, spp=1, seed=1)
        assert np.allclose(out[:, :, colour], 1.0, atol=1e-5)
        assert np.allclose(out[:, :, 2 - colour], 0.0, atol=1e-5)
    # A 90-degree rotation about y turns +x of the map to -z of the world.
    d = scene({"type": "environment", "file": "halves.exr", "transform": {"rotate": {"axis": [0, 1, 0], "angle": 90}}},
              [floor], {"m": {"type": "diffuse"}}, {"position": [0, 0, 0], "target": [0, 0, -1], "fov": 10}, res=8)
    out = render(d, tmp_path, spp=1, seed=1)
    assert np.allclose(out[:, :, 0], 1.0, atol=1e-5)


def sun_scene(tmp_path):
    h, w = 32, 64
    sky = np.zeros((h, w, 3), np.float32)
    theta = (np.arange(h) + 0.5) / h * math.pi
    sky[:] = (0.2 + 0.3 * np.cos(theta))[:, None, None].clip(0.05) * np.array([0.6, 0.8, 1.0], np.float32)
    sky[6:8, 40:42] = (400, 380, 300)  # a small, bright sun high in the sky
    caustica.write_image(tmp_path / "sky.exr", sky)
    return scene({"type": "environment", "file": "sky.exr"},
                 [{"type": "rectangle", "material": "floor",
                   "transform": {"scale": 20, "rotate": {"axis": [1, 0, 0], "angle": -90}}},
                  {"type": "cube", "material": "box", "transform": {"scale": 0.5, "translate": [0, 0.5, 0]}}],
                 {"floor": {"type": "diffuse", "reflectance": 0.5},
                  "box": {"type": "diffuse", "reflectance": [0.7, 0.3, 0.2]}},
                 {"position": [0, 6, 6], "target": [0, 0, 0], "fov": 30}, res=32)


def test_path_and_sppm_agree_under_a_sun_map(tmp_path):
    """Photons emitted from the map (importance-sampled) light the floor as the path tracer's
    NEE + MIS does. Whole-image mean: path (4 seeds x 64 spp) against SPPM (4 seeds x 64 passes,
    radius shrinking with alpha 0.7); the bound is 4 combined standard errors plus 3% for SPPM's
    remaining bias at the box's edges and shadow."""
    d = sun_scene(tmp_path)
    path = [render(d, tmp_path, spp=64, seed=s, max_depth=4).mean() for s in range(1, 5)]
    sppm = [render(d, tmp_path, integrator="sppm", spp=64, seed=s, max_depth=4).mean() for s in range(1, 5)]
    mp, sp = mean_and_se(path)
    ms, ss = mean_and_se(sppm)
    assert abs(mp - ms) < 4 * math.hypot(sp, ss) + 0.03 * mp, (mp, sp, ms, ss)


def test_importance_sampling_keeps_a_sun_quiet(tmp_path):
    """The sun (4 texels, 0.2% of the sphere) gives most of the floor's light. Sampled in
    proportion to the map, one light sample picks the sun about 3/4 of the time, so the
    per-render noise on the floor at 4 spp is about 0.3 x its level (Bernoulli spread of
    sun/sky picks); uniform sphere sampling would make it about 10 x the level (one sun hit in
    500 samples), and a density that missed the bilinear spill around the sun would add
    fireflies of hundreds. Bound: 0.45 x the level, and no pixel difference above 3 x level."""
    d = sun_scene(tmp_path)
    a = render(d, tmp_path, spp=4, seed=1, max_depth=2)
    b = render(d, tmp_path, spp=4, seed=2, max_depth=2)
    diff = a[24:, :, 0] - b[24:, :, 0]
    noise = np.std(diff) / math.sqrt(2)  # per-render noise on the floor
    level = a[24:, :, 0].mean()
    assert noise < 0.45 * level, (noise, level)
    assert np.abs(diff).max() < 3 * level, (np.abs(diff).max(), level)
