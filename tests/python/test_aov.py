"""Output variables (path's aov; integrator/path.h, Aov): each sample carries a quantity of the first surface its
camera ray reaches instead of radiance, averaged over the pixel. Checked against closed forms: the depth of a plane
seen by an orthographic camera, a sphere's normals and positions, a rectangle's texture coordinates, the albedo of
a textured and a vertex-coloured surface, zeros where nothing is hit, null boundaries seen through and media
ignored; the wavefront driver gives the same image; bad options are one line."""
import subprocess

import numpy as np
import pytest

import caustica

ORTHO = {"type": "orthographic", "position": [0, 0, 5], "target": [0, 0, 0], "view_size": 4, "width": 32,
         "height": 32}


def scene(shapes, **extra):
    d = {"camera": dict(ORTHO), "shapes": shapes, "lights": [{"type": "environment", "radiance": 1}]}
    d.update(extra)
    return d


def aov(s, kind, **kw):
    return np.asarray(caustica.render(s, aov=kind, spp=kw.pop("spp", 1), seed=1, jitter=False, **kw), np.float64)


PLANE = {"type": "rectangle", "transform": {"scale": 1.5, "translate": [0, 0, -1]}}


def pixel_centres():
    """World x, y of the pixel centres of the 32 x 32 orthographic view of width 4 (rows from the top)."""
    c = (np.arange(32) + 0.5) / 32 * 4 - 2
    return np.meshgrid(c, -c)


def test_depth_position_and_uv_of_a_plane():
    s = scene([PLANE])
    x, y = pixel_centres()
    inside = (np.abs(x) < 1.5) & (np.abs(y) < 1.5)
    d = aov(s, "depth")
    np.testing.assert_allclose(d[inside], 6.0, rtol=1e-6)  # from z = 5 to z = -1
    assert np.all(d[~inside] == 0)  # nothing hit: 0
    p = aov(s, "position")
    np.testing.assert_allclose(p[inside][:, 0], x[inside], atol=1e-5)
    np.testing.assert_allclose(p[inside][:, 1], y[inside], atol=1e-5)
    np.testing.assert_allclose(p[inside][:, 2], -1, atol=1e-6)
    uv = aov(s, "uv")  # the rectangle's (0, 0) is its corner (-1, -1) scaled: u = (x / 1.5 + 1) / 2
    np.testing.assert_allclose(uv[inside][:, 0], (x[inside] / 1.5 + 1) / 2, atol=1e-5)
    np.testing.assert_allclose(uv[inside][:, 1], (y[inside] / 1.5 + 1) / 2, atol=1e-5)
    np.testing.assert_allclose(aov(s, "geo_normal")[inside], [[0, 0, 1]] * int(inside.sum()), atol=1e-6)


def test_sphere_normals():
    s = scene([{"type": "sphere", "center": [0, 0, 0], "radius": 1.5}])
    x, y = pixel_centres()
    r2 = x ** 2 + y ** 2
    inside = r2 < 1.5 ** 2 * 0.98
    n = aov(s, "normal")[inside]
    want = np.stack([x[inside], y[inside], np.sqrt(1.5 ** 2 - r2[inside])], -1) / 1.5
    np.testing.assert_allclose(n, want, atol=2e-4)
    np.testing.assert_allclose(aov(s, "geo_normal")[inside], want, atol=2e-4)


def test_albedo_follows_textures_vertex_colours_and_material_kinds():
    mats = {"red": {"type": "diffuse", "reflectance": [0.8, 0.1, 0.1]},
            "gold": {"type": "conductor", "specular": [0.9, 0.7, 0.2]},
            "glass": {"type": "dielectric", "transmission": [0.3, 0.6, 0.9]},
            "vc": {"type": "diffuse", "reflectance": 0.5, "vertex_colors": True}}
    quads = [{"type": "rectangle", "material": m, "transform": {"scale": 0.9, "translate": [cx, cy, 0]}}
             for m, (cx, cy) in zip(("red", "gold", "glass"), ((-1, 1), (1, 1), (-1, -1)))]
    quads.append({"type": "mesh", "material": "vc", "positions": [[0.1, -1.9, 0], [1.9, -1.9, 0], [1.9, -0.1, 0],
                                                                     [0.1, -0.1, 0]],
                  "indices": [0, 1, 2, 0, 2, 3], "colors": [[0, 1, 0]] * 4})
    a = aov(scene(quads, materials=mats), "albedo")
    np.testing.assert_allclose(a[8, 8], [0.8, 0.1, 0.1], atol=1e-6)   # top left
    np.testing.assert_allclose(a[8, 24], [0.9, 0.7, 0.2], atol=1e-6)  # top right: the conductor's tint
    np.testing.assert_allclose(a[24, 8], [0.3, 0.6, 0.9], atol=1e-6)  # bottom left: the transmission
    np.testing.assert_allclose(a[24, 24], [0, 0.5, 0], atol=1e-6)     # bottom right: 0.5 times green


def test_null_boundaries_are_seen_through_and_media_ignored():
    fog = {"fog": {"type": "homogeneous", "sigma_t": 5, "albedo": 0.9}}
    box = {"type": "cube", "material": "boundary", "interior": "fog",
           "transform": {"scale": 0.5, "translate": [0, 0, 1]}}
    s = scene([PLANE, box], media=fog, materials={"boundary": {"type": "null"}})
    np.testing.assert_array_equal(aov(s, "depth"), aov(scene([PLANE]), "depth"))


def test_jittered_pixels_average_and_the_wavefront_agrees():
    s = scene([PLANE])
    d = np.asarray(caustica.render(s, aov="depth", spp=16, seed=2), np.float64)
    x, y = pixel_centres()
    inner = (np.abs(x) < 1.4) & (np.abs(y) < 1.4)
    np.testing.assert_allclose(d[inner], 6.0, rtol=1e-6)
    edge = d[(np.abs(x) > 1.45) & (np.abs(x) < 1.55) & (np.abs(y) < 1.0)]
    assert np.all((edge > 0) & (edge < 6))  # partly covered pixels average the plane and the 0 beside it
    w = np.asarray(caustica.render(s, aov="normal", spp=4, seed=2, wavefront=True), np.float64)
    np.testing.assert_array_equal(w, np.asarray(caustica.render(s, aov="normal", spp=4, seed=2), np.float64))


def test_bad_options():
    with pytest.raises(caustica.InputError, match=r"unknown AOV 'colour' \(allowed: depth, position, normal"):
        caustica.render(scene([PLANE]), aov="colour", spp=1)
    with pytest.raises(caustica.InputError, match="--aov applies to integrator 'path', got 'sppm'"):
        caustica.render(scene([PLANE]), aov="depth", integrator="sppm", spp=1)


def test_cli(caustica_bin, tmp_path):
    import json
    f = tmp_path / "s.json"
    f.write_text(json.dumps(scene([PLANE])))
    out = tmp_path / "d.exr"
    r = subprocess.run([caustica_bin, "render", str(f), "--aov", "depth", "--no-jitter", "--spp", "1", "--quiet",
                        "-o", str(out)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert caustica.read_image(str(out))[16, 16, 0] == pytest.approx(6.0, rel=1e-6)
    r = subprocess.run([caustica_bin, "render", str(f), "--aov", "colour", "-o", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "unknown AOV 'colour'" in r.stderr and "Traceback" not in r.stderr
