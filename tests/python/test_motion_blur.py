"""Camera motion blur: the shutter-averaged image of a moving camera, against its analytic value, for
every integrator that makes camera rays or connects to the lens; the scene format's checks; and the
options that a moving camera rules out."""
import json
import math
import subprocess

import numpy as np
import pytest

import caustica
from conftest import seeded_rows

W, H = 16, 8          # 0.5 scene units per pixel at the lit plane
L_LIT = 0.5           # radiance of the lit plane: albedo 0.5 / pi x irradiance pi


def moving_scene(shutter=(0.25, 0.75)):
    # A diffuse half-plane x > 0 (albedo 0.5) under a directional light straight down (irradiance pi),
    # seen head-on from 100 units. The camera translates by +8 along x between its two keyframes
    # (time 0 at x = -2, time 1 at x = 6); the shutter [0.25, 0.75] sees it move from x = 0 to x = 4.
    # A pixel whose centre is X units from the view axis sees the lit plane while 4 t + X > 0 for a
    # shutter fraction t in [0, 1): a linear ramp over X in [-4, 0] (8 pixels), lit beyond.
    fov = 2 * math.degrees(math.atan(4 / 100))
    cam = {"position": [-2, 0, 100], "target": [-2, 0, 0], "up": [0, 1, 0], "fov_axis": "x", "fov": fov,
           "width": W, "height": H,
           "motion": {"position": [6, 0, 100], "target": [6, 0, 0]},
           "shutter_open": shutter[0], "shutter_close": shutter[1]}
    return {
        "camera": cam, "filter": "box",
        "materials": {"grey": {"type": "diffuse", "reflectance": 0.5}},
        "shapes": [{"type": "rectangle", "material": "grey",
                    "transform": {"scale": [5, 4, 1], "translate": [5, 0, 0]}}],
        "lights": [{"type": "directional", "direction": [0, 0, -1], "irradiance": math.pi}],
    }


def expected_profile(shutter=(0.25, 0.75)):
    """Each column's value: the lit fraction of (time in the shutter) x (position in the pixel's box footprint)."""
    t = (np.arange(4000) + 0.5) / 4000
    cam_x = -2 + 8 * (shutter[0] + t * (shutter[1] - shutter[0]))   # camera x at each shutter time
    out = []
    for i in range(W):
        xs = -4 + 0.5 * i + (np.arange(200) + 0.5) / 200 * 0.5       # the pixel's footprint, relative to the axis
        out.append(L_LIT * np.mean(cam_x[:, None] + xs[None, :] > 0))
    return np.array(out)


@pytest.mark.parametrize("integrator,opts", [
    ("path", {"spp": 512}),
    ("light", {"spp": 32, "photons": 20000}),
    ("bdpt", {"spp": 64, "photons": 2000}),
    ("vcm", {"spp": 64, "photons": 2000, "radius": 0.01}),
    # SPPM's radius (0.05 units, a tenth of a pixel) blurs the ramp's two knees only; the linear part
    # is unchanged by a symmetric kernel.
    ("sppm", {"spp": 64, "photons": 20000, "radius": 0.05}),
])
def test_moving_camera_matches_the_shutter_average(integrator, opts):
    exp = expected_profile()
    # Two seeds x H rows: 16 independent estimates of each column's value (the rows see the same
    # profile). Light tracing's splats and SPPM's photons are shared by the pixels of a pass, but a
    # photon or splat lands in one pixel (radius 0.05 << the 0.5-unit rows), so the pixels' estimates
    # are multinomially, i.e. negatively, correlated, which only makes the spread a conservative
    # standard error.
    vals = seeded_rows(moving_scene(), integrator, **opts)  # (2H, W)
    n = vals.shape[0]
    mean = vals.mean(axis=0)
    se = vals.std(axis=0, ddof=1) / math.sqrt(n)
    for i in range(W):
        # 5 standard errors (t with 15 dof: two-sided p ~ 2e-4 per column, 64 columns in all), and 1e-3 for
        # the perspective of the pixel grid and a column whose estimates are all equal (fully lit: path).
        assert abs(mean[i] - exp[i]) < 5 * se[i] + 1e-3, (integrator, i, mean[i], exp[i], se[i])
    # The ramp is there: the first column is mostly dark, the right half fully lit.
    assert exp[0] < 0.05 and np.all(exp[8:] == L_LIT)


def test_static_shutter_sees_one_pose():
    # A shutter closed at time 0.5 (open = close): a static camera at x = 2, a sharp edge 4 units left
    # of the axis; the renders equal those of a camera placed there.
    s = moving_scene(shutter=(0.5, 0.5))
    still = moving_scene()
    del still["camera"]["motion"], still["camera"]["shutter_open"], still["camera"]["shutter_close"]
    still["camera"]["position"] = [2, 0, 100]
    still["camera"]["target"] = [2, 0, 0]
    a = caustica.render(s, spp=16, seed=3)
    b = caustica.render(still, spp=16, seed=3)
    assert np.array_equal(a, b)


def test_motion_round_trips_through_export(tmp_path):
    src = tmp_path / "m.json"
    src.write_text(json.dumps(moving_scene()))
    out = tmp_path / "exported.json"
    caustica.export_scene(str(src), str(out))
    cam = json.loads(out.read_text())["camera"]
    assert cam["motion"]["position"] == [6, 0, 100]
    assert cam["shutter_open"] == 0.25 and cam["shutter_close"] == 0.75
    a = caustica.render(str(src), spp=8, seed=4)
    b = caustica.render(str(out), spp=8, seed=4)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("edit,where", [
    (lambda c: c.update(shutter_open=-0.1), "/camera/shutter_open"),
    (lambda c: c.update(shutter_open=0.6, shutter_close=0.5), "/camera/shutter_close"),
    (lambda c: c.update(shutter_close=1.5), "/camera/shutter_close"),
    (lambda c: c["motion"].update(target=[6, 0, 100]), "/camera/motion/target"),
    (lambda c: c["motion"].update(up=[0, 0, 1]), "/camera/motion/up"),
    (lambda c: c["motion"].update(speed=3), "/camera/motion"),
    (lambda c: c.update(motion=[1, 2, 3]), "/camera/motion"),
])
def test_bad_motion_is_one_line_naming_the_json_path(tmp_path, caustica_bin, edit, where):
    s = moving_scene()
    edit(s["camera"])
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(s))
    r = subprocess.run([caustica_bin, "render", str(f), "--spp", "1", "-o", str(tmp_path / "o.exr")],
                       capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and where in lines[0] and "bad.json" in lines[0], r.stderr
    assert "Traceback" not in r.stderr


def test_first_bounce_cache_refuses_a_moving_camera(tmp_path, caustica_bin):
    f = tmp_path / "m.json"
    f.write_text(json.dumps(moving_scene()))
    r = subprocess.run([caustica_bin, "render", str(f), "--wavefront", "--no-jitter", "--cache-first-bounce",
                        "--spp", "1", "-o", str(tmp_path / "o.exr")], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert "--cache-first-bounce" in r.stderr and "moves" in r.stderr and "Traceback" not in r.stderr


def moving_spheres(tmp_path, aperture=0.0):
    """SmallVCM's spheres with the camera turning and sliding while the shutter is open."""
    base = tmp_path / "spheres.json"
    caustica.export_scene("smallvcm-spheres", str(base))
    d = json.loads(base.read_text())
    c = d["camera"]
    p, t = c["position"], c["target"]
    c["motion"] = {"position": [p[0] + 0.3, p[1], p[2] + 0.1], "target": [t[0] + 0.6, t[1], t[2]]}
    c["width"], c["height"] = 24, 20
    if aperture:
        c["aperture_radius"] = aperture
    f = tmp_path / "moving.json"
    f.write_text(json.dumps(d))
    return caustica.load_scene(str(f))


@pytest.mark.parametrize("aperture", [0.0, 0.05])
def test_wavefront_draws_the_same_times_as_the_cpu_drivers(tmp_path, aperture):
    # The wavefront drivers (the CUDA backend's code, run on the CPU) draw each path's time where the
    # CPU drivers do: bit for bit for path and the bidirectional integrators, to rounding for sppm.
    s = moving_spheres(tmp_path, aperture)
    for integrator in ("path", "light", "bdpt", "vcm", "upg"):
        ref = caustica.render(s, integrator=integrator, spp=2, seed=8)
        img = caustica.render(s, integrator=integrator, spp=2, seed=8, wavefront=True)
        assert np.array_equal(img, ref), integrator
    ref = caustica.render(s, integrator="sppm", spp=3, seed=4)
    img = caustica.render(s, integrator="sppm", spp=3, seed=4, wavefront=True)
    np.testing.assert_allclose(img, ref, rtol=1e-5, atol=1e-9)
    # And the motion shows: the static camera's image is another one.
    d = json.loads((tmp_path / "moving.json").read_text())
    del d["camera"]["motion"]
    (tmp_path / "still.json").write_text(json.dumps(d))
    still = caustica.render(str(tmp_path / "still.json"), integrator="path", spp=2, seed=8)
    moving = caustica.render(s, integrator="path", spp=2, seed=8)
    assert np.abs(still - moving).mean() > 0.05 * np.abs(still).mean()


@pytest.mark.skipif(not caustica.cuda_status()[0], reason=f"no CUDA device: {caustica.cuda_status()[1]}")
@pytest.mark.parametrize("integrator", ["path", "sppm", "vcm"])
def test_gpu_moving_camera_matches_the_cpu_per_region(tmp_path, integrator):
    from test_bidirectional import seeded_regions
    s = moving_spheres(tmp_path)
    m_cpu, se_cpu = seeded_regions(s, integrator, 8, range(100, 112))
    m_gpu, se_gpu = seeded_regions(s, integrator, 8, range(200, 212), device="cuda")
    z = np.abs(m_cpu - m_gpu) / np.sqrt(se_cpu ** 2 + se_gpu ** 2)
    assert z.max() < 4.0, np.round(z, 1)


def test_lane_parallel_path_tracer_draws_the_same_times(tmp_path):
    # Cornell (untextured diffuse walls, a triangle area light) is the eight-lane driver's; with a moving
    # camera its image is the one-path-at-a-time tracer's bit for bit.
    base = tmp_path / "cornell.json"
    caustica.export_scene("cornell", str(base))
    d = json.loads(base.read_text())
    c = d["camera"]
    c["motion"] = {"position": [c["position"][0] + 0.2, c["position"][1], c["position"][2]]}
    c["width"], c["height"] = 20, 16
    (tmp_path / "moving.json").write_text(json.dumps(d))
    s = caustica.load_scene(str(tmp_path / "moving.json"))
    lanes = caustica.render_job(s, spp=3, seed=2)
    one = caustica.render_job(s, spp=3, seed=2, lanes=False)
    if lanes.stats["lanes"] != 8:
        pytest.skip("the eight-lane driver needs AVX2")
    assert one.stats["lanes"] == 0
    assert np.array_equal(lanes.image, one.image)


def test_info_reports_the_shutter(tmp_path, caustica_bin):
    d = caustica.describe(moving_scene())
    assert d["shutter"] == (0.25, 0.75) and d["projection"] == "perspective"
    assert caustica.describe("cornell")["shutter"] is None
    f = tmp_path / "m.json"
    f.write_text(json.dumps(moving_scene()))
    r = subprocess.run([caustica_bin, "info", str(f), "--json"], capture_output=True, text=True)
    assert r.returncode == 0 and json.loads(r.stdout)["shutter"] == [0.25, 0.75], r.stdout + r.stderr
    r = subprocess.run([caustica_bin, "info", str(f)], capture_output=True, text=True)
    assert "moving camera (motion blur, shutter 0.25 to 0.75)" in r.stdout, r.stdout
