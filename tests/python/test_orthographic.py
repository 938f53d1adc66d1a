"""The orthographic camera: parallel rays (what it sees does not shrink with distance), its light-tracing
importance against the analytic radiance of a tilted lit plane for every integrator, the wavefront drivers,
and the scene formats (JSON, Mitsuba XML; glTF in tests/cpp/test_gltf_loader.cpp)."""
import json
import math
import subprocess

import numpy as np
import pytest

import caustica
from conftest import seeded_rows


def two_squares(depth_b):
    # Two emitting 2 x 2 squares, one at z = 0 (left, x in [-3, -1]) and one at z = -depth_b (right, x in
    # [1, 3]), seen straight down the z axis by an orthographic camera 8 units wide over 16 pixels, so
    # square edges fall on pixel boundaries (0.5 units per pixel).
    return {
        "camera": {"type": "orthographic", "view_size": 8, "fov_axis": "x", "position": [0, 0, 10],
                   "target": [0, 0, 0], "up": [0, 1, 0], "width": 16, "height": 8},
        "filter": "box",
        "materials": {"black": {"type": "diffuse", "reflectance": 0.0}},
        "shapes": [
            {"type": "rectangle", "material": "black", "emission": 1.0, "transform": {"translate": [-2, 0, 0]}},
            {"type": "rectangle", "material": "black", "emission": 1.0,
             "transform": {"translate": [2, 0, -depth_b]}},
        ],
    }


@pytest.mark.parametrize("depth_b", [0.0, 50.0])
def test_parallel_rays_see_sizes_independent_of_distance(depth_b):
    img = caustica.render(two_squares(depth_b), spp=16, max_depth=1, seed=1)[:, :, 0]
    # Every pixel lies wholly on or off a square: exactly 1 or 0, whatever the depth (a perspective
    # camera would shrink the far square).
    cols = np.zeros(16)
    cols[2:6] = 1.0   # x in [-3, -1]
    cols[10:14] = 1.0  # x in [1, 3]
    rows = np.zeros(8)
    rows[2:6] = 1.0    # y in [-1, 1]
    assert np.array_equal(img, np.outer(rows, cols).astype(np.float32))


TILT = 60.0  # degrees between the plane's normal and the view axis


def tilted_plane():
    """A diffuse plane z = 0 (albedo 0.5) under a directional light straight down (irradiance pi):
    radiance 0.5 everywhere. The orthographic camera looks at it TILT degrees off its normal, so a
    light vertex's cosine towards the camera is cos(TILT), the factor the camera's importance takes."""
    t = math.radians(TILT)
    return {
        "camera": {"type": "orthographic", "view_size": 2, "position": [0, -10 * math.sin(t), 10 * math.cos(t)],
                   "target": [0, 0, 0], "up": [0, 0, 1], "width": 8, "height": 8},
        "filter": "box",
        "materials": {"grey": {"type": "diffuse", "reflectance": 0.5}},
        # The view covers 2 x 2 / cos(TILT) = 2 x 4 units of the plane; the plane is 6 x 6.
        "shapes": [{"type": "rectangle", "material": "grey", "transform": {"scale": 3}}],
        "lights": [{"type": "directional", "direction": [0, 0, -1], "irradiance": math.pi}],
    }


@pytest.mark.parametrize("integrator,opts", [
    ("path", {"spp": 16}),
    ("light", {"spp": 32, "photons": 20000}),
    # bdpt, vcm, upg: NEE and light tracing both sample these paths, so the weights depend on the camera's
    # density at the first vertex; with it taken per solid angle (1/d^2 too many) they are 5% low, which
    # this many passes puts at > 10 standard errors.
    ("bdpt", {"spp": 128, "photons": 2000}),
    ("vcm", {"spp": 128, "photons": 2000, "radius": 0.02}),
    ("upg", {"spp": 128, "photons": 2000, "radius": 0.02}),
    # sppm, pppm: a delta light and one plane leave no indirect light, so this checks their camera
    # passes only (the direct light of the visible points).
    ("sppm", {"spp": 8, "photons": 2000, "radius": 0.05}),
    ("pppm", {"spp": 8, "photons": 2000, "radius": 0.05}),
])
def test_orthographic_importance_matches_the_analytic_radiance(integrator, opts):
    # Every pixel's expected value is 0.5. Two seeds x 64 pixels: 128 estimates (a pass's splats and
    # photons land in one pixel each, so pixels are independent or negatively correlated: the spread is a
    # conservative standard error). The mean within 5 standard errors, and no pixel further than 6 of
    # its own (128 pixels: two-sided p ~ 2e-9 each under normality).
    v = seeded_rows(tilted_plane(), integrator, **opts).ravel()
    se = v.std(ddof=1) / math.sqrt(v.size)
    # path: NEE of a delta light on a uniform plane gives exactly 0.5 in every sample (se = 0): allow
    # float rounding.
    assert abs(v.mean() - 0.5) < 5 * se + 1e-5, (integrator, v.mean(), se)
    assert np.all(np.abs(v - 0.5) < 6 * v.std(ddof=1) + 1e-5), (integrator, v.min(), v.max())


def test_wavefront_gives_the_cpu_drivers_orthographic_images():
    s = caustica.load_dict(tilted_plane())
    for integrator in ("path", "light", "bdpt", "vcm"):
        ref = caustica.render(s, integrator=integrator, spp=2, seed=8)
        img = caustica.render(s, integrator=integrator, spp=2, seed=8, wavefront=True)
        assert np.array_equal(img, ref), integrator


def test_export_round_trip(tmp_path):
    src = tmp_path / "o.json"
    src.write_text(json.dumps(two_squares(5.0)))
    out = tmp_path / "e.json"
    caustica.export_scene(str(src), str(out))
    cam = json.loads(out.read_text())["camera"]
    assert cam["type"] == "orthographic" and cam["view_size"] == 8 and "fov" not in cam
    assert np.array_equal(caustica.render(str(src), spp=4, seed=2), caustica.render(str(out), spp=4, seed=2))


def test_mitsuba_orthographic_sensor_matches_the_json_camera(tmp_path):
    # The same view two ways: JSON view_size 4 across x; Mitsuba's to_world scale 2 (the sensor sees
    # [-2, 2] across x). bench/compare_mitsuba_xml.py compares with Mitsuba 3 itself.
    j = {"camera": {"type": "orthographic", "view_size": 4, "fov_axis": "x", "position": [0, 0, 5],
                    "target": [0, 0, 0], "up": [0, 1, 0], "width": 16, "height": 8},
         "filter": "box", "materials": {"black": {"type": "diffuse", "reflectance": 0.0}},
         "shapes": [{"type": "rectangle", "material": "black", "emission": 1.0,
                     "transform": {"scale": [0.75, 0.5, 1], "translate": [0.25, 0, 0]}}]}
    ref = caustica.render(j, spp=16, max_depth=1, seed=1)
    assert 0 < ref.mean() < 1
    xml = tmp_path / "o.xml"
    xml.write_text("""<scene version="3.0.0">
  <sensor type="orthographic">
    <transform name="to_world"><scale x="2" y="2"/><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="8"/><rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle"><transform name="to_world"><scale x="0.75" y="0.5"/><translate x="0.25"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
    <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>""")
    assert np.array_equal(caustica.render(str(xml), spp=16, max_depth=1, seed=1), ref)
    # (glTF's xmag / ymag: tests/cpp/test_gltf_loader.cpp, GltfLoader.CamerasDefaultAndByName.)


@pytest.mark.parametrize("edit,where,what", [
    ({"fov": 30}, "/camera/fov", "applies to a perspective camera"),
    ({"aperture_radius": 0.1}, "/camera/aperture_radius", "applies to a perspective camera"),
    ({"view_size": 0}, "/camera/view_size", "expected the view's width"),
    ({"type": "fisheye"}, "/camera/type", "allowed: perspective, orthographic"),
])
def test_bad_orthographic_camera_is_one_line(tmp_path, caustica_bin, edit, where, what):
    s = two_squares(0.0)
    s["camera"].update(edit)
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(s))
    r = subprocess.run([caustica_bin, "render", str(f), "--spp", "1", "-o", str(tmp_path / "o.exr")],
                       capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and where in lines[0] and what in lines[0], r.stderr


def test_view_size_on_a_perspective_camera_is_an_error(tmp_path, caustica_bin):
    s = two_squares(0.0)
    s["camera"]["type"] = "perspective"
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(s))
    r = subprocess.run([caustica_bin, "render", str(f), "--spp", "1", "-o", str(tmp_path / "o.exr")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "/camera/view_size" in r.stderr and "orthographic" in r.stderr, r.stderr


def test_info_names_the_projection(tmp_path, caustica_bin):
    assert caustica.describe(two_squares(0.0))["projection"] == "orthographic"
    f = tmp_path / "o.json"
    f.write_text(json.dumps(two_squares(0.0)))
    r = subprocess.run([caustica_bin, "info", str(f)], capture_output=True, text=True)
    assert r.returncode == 0 and "projection:  orthographic" in r.stdout, r.stdout + r.stderr
    assert caustica.describe("cornell")["projection"] == "perspective"
