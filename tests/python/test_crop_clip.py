"""Crop windows (a part of the film) and the camera's clipping planes, through every kind of estimator."""
import json
import math
import subprocess

import numpy as np
import pytest

import caustica
from conftest import BIN, region_means

CROP = (20, 8, 32, 32)  # x, y, width, height of the 64 x 64 film


def cornell(**camera):
    d = json.loads(caustica.load_scene("cornell").to_json())
    d["film"] = {"width": 64, "height": 64, "filter": "gaussian"}
    d["camera"].update(camera)
    return d


def region_z(a, b, k=4):
    """Largest difference of the green means of a k x k grid of regions, in units of their combined standard error
    (from each region's pixel spread, an upper bound on the noise)."""
    ma, sa = region_means(a, k)
    mb, sb = region_means(b, k)
    return float((np.abs(ma - mb) / (np.sqrt(sa ** 2 + sb ** 2) + 1e-9)).max())


OPTS = {"path": dict(spp=64), "light": dict(spp=16), "bdpt": dict(spp=16), "vcm": dict(spp=16),
        "sppm": dict(spp=16, photons=20000, radius=0.03)}


@pytest.mark.parametrize("integrator", list(OPTS))
def test_crop_is_that_part_of_the_whole_render(integrator):
    full = caustica.render(caustica.load_scene(cornell()), integrator=integrator, seed=1, **OPTS[integrator])
    s = caustica.load_scene(cornell(), crop=CROP)
    assert (s.width, s.height, s.film_size, s.crop) == (32, 32, (64, 64), CROP)
    part = caustica.render(s, integrator=integrator, seed=2, **OPTS[integrator])
    x, y, w, h = CROP
    assert part.shape == (h, w, 3)
    # 8 x 8 pixel regions: the two renders agree within 4.5 standard errors (16 regions; sppm's fixed radius
    # gives both the same bias).
    assert region_z(part, full[y:y + h, x:x + w]) < 4.5
    # The test can tell a wrong window: the same comparison one window-width off fails.
    assert region_z(part, full[y:y + h, x - 16:x - 16 + w]) > 8


@pytest.mark.parametrize("sampler", ["sobol", "independent"])
def test_a_crop_draws_the_whole_renders_samples(sampler):
    """The samplers are seeded by a pixel's index in the uncropped film, so with the same seed the path tracer's
    crop is that part of the whole render sample for sample, not only in expectation: equal up to the rays'
    rounding (the crop's image-plane window is computed apart) in nearly every pixel, where a render with
    another seed (as the crop was before, seeded by its own pixel indices) matches in almost none."""
    opts = dict(integrator="path", spp=4, sampler=sampler)
    full = caustica.render(caustica.load_scene(cornell()), seed=7, **opts)
    other = caustica.render(caustica.load_scene(cornell()), seed=8, **opts)
    part = caustica.render(caustica.load_scene(cornell(), crop=CROP), seed=7, **opts)
    x, y, w, h = CROP

    def matching(a):
        return np.isclose(part, a[y:y + h, x:x + w], rtol=1e-4, atol=1e-6).all(axis=2).mean()

    assert matching(full) > 0.99, matching(full)
    assert matching(other) < 0.05, matching(other)


def test_crop_with_a_thin_lens_and_a_negative_lobed_filter():
    d = cornell(aperture_radius=0.1, focus_distance=2.5)
    d["film"]["filter"] = "mitchell"
    x, y, w, h = CROP
    for integrator in ("path", "light"):
        full = caustica.render(d, integrator=integrator, seed=3, **OPTS[integrator])
        part = caustica.render(caustica.load_scene(d, crop=CROP), integrator=integrator, seed=4, **OPTS[integrator])
        assert region_z(part, full[y:y + h, x:x + w]) < 4.5, integrator


def test_crop_in_the_scene_file_and_its_errors(tmp_path):
    d = cornell()
    d["film"]["crop"] = list(CROP)
    s = caustica.load_scene(d)
    assert s.crop == CROP and (s.width, s.height) == (32, 32)
    # The export keeps it.
    p = tmp_path / "c.json"
    s.write_json(str(p))
    assert json.loads(p.read_text())["film"]["crop"] == list(CROP)
    assert caustica.load_scene(str(p)).crop == CROP
    # The API replaces or removes it; width/height are the film's.
    assert caustica.load_scene(d, crop=(0, 0, 0, 0)).crop is None
    s2 = caustica.load_scene(d, width=128, height=128, crop=(100, 0, 28, 10))
    assert (s2.film_size, s2.crop, s2.width, s2.height) == ((128, 128), (100, 0, 28, 10), 28, 10)
    for bad, msg in ((["a", 0, 1, 1], "/film/crop/0"), ([-1, 0, 32, 32], "/film/crop"), ([0, 0, 0, 4], "/film/crop"), ([40, 0, 32, 32], "/film/crop"),
                     ([0, 0, 1], "/film/crop")):
        d["film"]["crop"] = bad
        with pytest.raises(caustica.SceneError, match=msg):
            caustica.load_scene(d)
    d["film"]["crop"] = [40, 0, 32, 32]
    with pytest.raises(caustica.SceneError, match="does not fit the 64x64 film"):
        caustica.load_scene(d)
    # A window that does not fit leaves a loaded scene as it was.
    s = caustica.load_scene(cornell(), crop=CROP)
    with pytest.raises(caustica.InputError, match="does not fit the 40x40 film"):
        caustica.load_scene(s, width=40, height=40)
    assert (s.film_size, s.crop) == ((64, 64), CROP)
    # So does a filter that fails after a new resolution and window were set, and the filter stays the scene's.
    before = (s.filter, s.filter_parameters)
    for bad, msg in (({"type": "lanczos", "lobes": 0.5}, "lobes"), ("bicubic", "unknown filter")):
        with pytest.raises(caustica.InputError, match=msg):
            caustica.load_scene(s, width=48, height=48, crop=(0, 0, 16, 16), filter=bad)
        assert (s.film_size, s.crop, (s.filter, s.filter_parameters)) == ((64, 64), CROP, before)
    with pytest.raises(caustica.InputError, match="crop: expected"):
        caustica.load_scene(cornell(), crop=(1, 2))


def test_crop_on_the_command_line(tmp_path):
    p = tmp_path / "c.json"
    p.write_text(json.dumps(cornell()))
    out = tmp_path / "o.exr"
    r = subprocess.run([BIN, "render", str(p), "--spp", "1", "--crop", "20", "8", "32", "16", "-o", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "32x16" in r.stderr
    info = subprocess.run([BIN, "info", str(p)], capture_output=True, text=True).stdout
    assert "64x64" in info and "crop" not in info
    d = cornell(near_clip=0.5)
    d["film"]["crop"] = [20, 8, 32, 16]
    p.write_text(json.dumps(d))
    info = subprocess.run([BIN, "info", str(p)], capture_output=True, text=True).stdout
    assert "32x16 (crop at 20, 8 of the 64x64 film)" in info and "clipped to depths 0.5 to inf" in info
    js = json.loads(subprocess.run([BIN, "info", "--json", str(p)], capture_output=True, text=True).stdout)
    assert js["crop"] == [20, 8, 32, 16] and js["film_size"] == [64, 64] and js["clip"] == [0.5, None]
    r = subprocess.run([BIN, "render", str(p), "--crop", "60", "0", "8", "8", "-o", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "does not fit the 64x64 film" in r.stderr and "Traceback" not in r.stderr
    r = subprocess.run([BIN, "render", str(p), "--crop", "1", "2", "3"], capture_output=True, text=True)
    assert r.returncode == 2 and "--crop" in r.stderr


# The near plane: a black card just in front of the lens (depth 0.4, covering the whole view) disappears when
# the near plane lies beyond it; light-tracing connections to the lens must not be blocked by it either. The plane
# at depth 2.5, just before the box (2.9), makes the camera's first segment much longer than the clipped ray:
# bdpt's and vcm's MIS weights, which need the segment from the lens, are off by 16 standard errors without it.
def card_scene(near):
    d = cornell(near_clip=near) if near else cornell()
    d["materials"]["black"] = {"type": "diffuse", "reflectance": 0.0}
    d["shapes"].append({"type": "rectangle", "material": "black", "transform": {"translate": [0, 0, 3.5]}})
    return d


@pytest.mark.parametrize("integrator", ["path", "light", "bdpt", "vcm"])
@pytest.mark.parametrize("driver", ["cpu", "wavefront"])
def test_near_plane_cuts_away_what_is_in_front_of_it(integrator, driver):
    run = dict(wavefront=True) if driver == "wavefront" else {}
    assert caustica.render(card_scene(0), integrator=integrator, spp=1, **run).max() == 0.0  # the card hides all
    ref = caustica.render(cornell(), integrator="path", seed=1, spp=64)
    img = caustica.render(card_scene(2.5), integrator=integrator, seed=2, **OPTS[integrator], **run)
    assert region_z(img, ref) < 4.5


# The far plane at depth 4.5 cuts the back wall (depth 4.9) away: its pixels see nothing, and light paths
# do not reach the lens from it either.
@pytest.mark.parametrize("integrator", ["path", "light", "bdpt", "vcm"])
def test_far_plane_cuts_away_what_is_beyond_it(integrator):
    img = caustica.render(cornell(far_clip=4.5), integrator=integrator, seed=2, **OPTS[integrator])
    assert img[18:24, 22:46].max() == 0.0  # the back wall above the tall box, nothing else behind it
    ref = caustica.render(cornell(far_clip=4.5), integrator="path", seed=1, spp=64)
    assert region_z(img, ref) < 4.5
    # and differs from the unclipped box (the back wall is bright)
    full = caustica.render(cornell(), integrator="path", seed=1, spp=16)
    assert full[18:24, 22:46, 1].mean() > 0.1


def test_clip_values_in_the_scene_file(tmp_path):
    import os
    import jsonschema
    d = cornell(near_clip=0.25, far_clip=20, principal_point=[0.1, 0])
    d["film"]["crop"] = [3, 4, 50, 40]
    s = caustica.load_scene(d)
    assert s.describe()["clip"] == pytest.approx((0.25, 20.0))
    p = tmp_path / "c.json"
    s.write_json(str(p))
    doc = json.loads(p.read_text())
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    jsonschema.Draft202012Validator(json.load(open(os.path.join(root, "docs", "scene.schema.json")))).validate(doc)
    assert doc["camera"]["near_clip"] == 0.25 and doc["camera"]["far_clip"] == 20
    assert np.array_equal(caustica.render(s, spp=4, seed=5), caustica.render(str(p), spp=4, seed=5))
    assert caustica.load_scene(cornell()).describe()["clip"] is None
    for cam, msg in (({"near_clip": -1}, "/camera/near_clip"), ({"far_clip": 0}, "/camera/far_clip"),
                     ({"near_clip": 2, "far_clip": 1}, "/camera/far_clip"), ({"near_clip": "a"}, "/camera/near_clip")):
        with pytest.raises(caustica.SceneError, match=msg):
            caustica.load_scene(cornell(**cam))


def test_mitsuba_crop_and_clip(tmp_path):
    xml = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/><float name="near_clip" value="0.5"/>
    <float name="far_clip" value="50"/>
    <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>
      <integer name="crop_offset_x" value="8"/><integer name="crop_offset_y" value="4"/>
      <integer name="crop_width" value="40"/><integer name="crop_height" value="30"/></film></sensor>
  <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter></shape>
</scene>"""
    p = tmp_path / "s.xml"
    p.write_text(xml)
    s = caustica.load_scene(str(p))
    assert (s.film_size, s.crop, s.width, s.height) == ((64, 48), (8, 4, 40, 30), 40, 30)
    assert s.describe()["clip"] == pytest.approx((0.5, 50.0))
    assert not any("near_clip" in w for w in s.warnings)
    # Mitsuba's defaults, 0.01 and 10000, when the sensor gives none
    p.write_text(xml.replace('<float name="near_clip" value="0.5"/>', "").replace(
        '<float name="far_clip" value="50"/>', ""))
    assert caustica.load_scene(str(p)).describe()["clip"] == pytest.approx((0.01, 1e4))
    p.write_text(xml.replace('value="40"/><integer name="crop_height"', 'value="60"/><integer name="crop_height"'))
    with pytest.raises(caustica.SceneError, match=r"s\.xml:5: .*does not fit the 64x48 film"):
        caustica.load_scene(str(p))


CUDA, WHY = caustica.cuda_status()


# The same on the GPU: a crop window and both clipping planes, against the CPU's path tracer.
@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
@pytest.mark.parametrize("integrator", ["path", "light", "bdpt", "vcm", "sppm"])
def test_cuda_crop_and_clip(integrator):
    d = card_scene(2.5)
    d["camera"]["far_clip"] = 4.5
    ref = caustica.render(caustica.load_scene(d, crop=CROP), integrator="path", seed=1, spp=256)
    img = caustica.render(caustica.load_scene(d, crop=CROP), integrator=integrator, seed=2, device="cuda",
                          **OPTS[integrator])
    assert img.shape == ref.shape == (32, 32, 3)
    assert region_z(img, ref) < 4.5


# The principal point offset (a shift lens): the image is the centred camera's, moved by (x W, y H) pixels.
def test_principal_point_moves_the_image(tmp_path):
    d = cornell(principal_point=[0.125, -0.25])  # 8 pixels right, 16 up
    s = caustica.load_scene(d)
    shifted = caustica.render(s, seed=1, spp=64)
    big = cornell()
    big["film"] = {"width": 128, "height": 128, "filter": "gaussian", "crop": [32 + 8, 32 - 16, 64, 64]}
    big["camera"]["fov"] = 2 * math.degrees(math.atan(2 * math.tan(math.radians(39.3077 / 2))))
    same = caustica.render(caustica.load_scene(big), seed=2, spp=64)  # that window of a twice-as-wide view
    assert region_z(shifted, same) < 4.5
    assert region_z(shifted, caustica.render(cornell(), seed=2, spp=64)) > 8  # and not the centred image
    p = tmp_path / "c.json"
    s.write_json(str(p))
    assert json.loads(p.read_text())["camera"]["principal_point"] == [0.125, -0.25]
    for bad, msg in ((0.1, "/camera/principal_point"), ([0.1, "a"], "/camera/principal_point/1")):
        with pytest.raises(caustica.SceneError, match=msg):
            caustica.load_scene(cornell(principal_point=bad))
    xml = """<scene version="3.0.0"><sensor type="SENSOR"><float name="principal_point_offset_x" value="0.1"/>
    <float name="principal_point_offset_y" value="-0.2"/>APERTURE</sensor>
  <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter></shape></scene>"""
    x = tmp_path / "s.xml"
    x.write_text(xml.replace("SENSOR", "perspective").replace("APERTURE", ""))
    x_json = tmp_path / "x.json"
    caustica.load_scene(str(x)).write_json(str(x_json))
    doc = json.loads(x_json.read_text())
    cam = doc["camera"] if isinstance(doc["camera"], dict) else doc["cameras"][doc["camera"]]
    assert cam["principal_point"] == pytest.approx([0.1, -0.2])
    x.write_text(xml.replace("SENSOR", "thinlens").replace("APERTURE", '<float name="aperture_radius" value="0.1"/>'))
    with pytest.raises(caustica.SceneError, match="applies to a perspective sensor"):
        caustica.load_scene(str(x))


def test_photon_radius_counts_from_the_lens():
    # The automatic gather radius (a pixel's footprint at the median hit) is measured from the lens, so a near
    # plane in front of everything leaves it unchanged.
    def radius(d):
        return caustica.render_job(d, "sppm", 1, None, 0, 0, None, None, None, "auto", None).stats["radius"]
    assert radius(cornell(near_clip=2.5)) == pytest.approx(radius(cornell()), rel=1e-5)
