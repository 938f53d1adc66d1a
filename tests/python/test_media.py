"""Participating media in the path tracer (medium/medium.h, integrator/path.h).

Furnace tests with analytic answers: a camera at the centre of a null sphere of radius R filled with a
homogeneous medium, under a constant environment Le. A pure absorber shows Le exp(-sigma_a R) in every
pixel; a medium that only scatters (albedo 1) shows Le exactly, whatever sigma_s and g (radiance is
conserved: the equilibrium is L = Le everywhere), which exercises distance sampling, NEE through the null
boundary with the media's transmittance, and its MIS with phase sampling. A cross-check between two
implementations: glass with the material's Beer-Lambert `absorption` against the same glass filled with
an absorbing medium. Pixels are independent estimates, so their spread gives the standard error."""
import json
import os
import subprocess
import sys

import jsonschema
import numpy as np
import pytest

import caustica
from conftest import mean_and_se

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
R = 2.0
LE = [1.0, 0.5, 2.0]


def medium_sphere(medium, boundary="null", camera_inside=True, env=LE, width=24):
    mats = {"boundary": {"type": boundary}} if boundary == "null" else {"boundary": boundary}
    cam = {"position": [0, 0, 0], "target": [0.3, 0.2, -1], "up": [0, 1, 0], "fov": 100,
           "width": width, "height": width}
    if camera_inside:
        cam["medium"] = "m"
    return {
        "camera": cam,
        "media": {"m": medium},
        "materials": mats,
        "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": R, "material": "boundary", "interior": "m"}],
        "lights": [{"type": "environment", "radiance": env}],
    }


def assert_pixel_means(img, expected, k=4.0):
    """Each channel's mean over the pixels (independent estimates) within k standard errors of `expected`."""
    for c in range(3):
        m, se = mean_and_se(img[..., c])
        assert se > 0.0
        assert abs(m - expected[c]) < k * se, (c, m, expected[c], se)


def test_absorbing_medium_is_beer_lambert():
    sa = np.array([0.2, 0.5, 1.0])
    img = caustica.render(medium_sphere({"sigma_a": sa.tolist(), "sigma_s": 0.0}), spp=64, seed=1, max_depth=-1)
    expected = np.array(LE) * np.exp(-sa * R)
    assert_pixel_means(img, expected)  # 4 standard errors of the 576-pixel mean


@pytest.mark.parametrize("g", [0.0, 0.7, -0.4])
@pytest.mark.parametrize("sampler", ["sobol", "independent"])
def test_scattering_furnace(g, sampler):
    # sigma_s differs per channel (the spectral MIS of distance sampling); optical radius 1.6 to 2.5. Measured
    # over 8 seeds for each case: |z| <= 2.4.
    medium = {"sigma_a": 0.0, "sigma_s": [0.8, 1.0, 1.25], "g": g}
    img = caustica.render(medium_sphere(medium), spp=64, seed=2, max_depth=-1, sampler=sampler)
    assert_pixel_means(img, LE)  # 4 standard errors of the 576-pixel mean


def test_scattering_furnace_strongly_spectral():
    # sigma_s 0.5 / 1 / 1.5: a channel's weight per event is up to 3x another's, so the densest channel's
    # estimates are heavy-tailed (at 64 spp its z-scores over 8 seeds lean low, to -4.5); at 512 spp, without
    # roulette (the throughput's spread would steer it), the mean is within 4 standard errors (measured
    # 1.996 +- 0.012 for Le 2).
    medium = {"sigma_a": 0.0, "sigma_s": [0.5, 1.0, 1.5]}
    img = caustica.render(medium_sphere(medium), spp=512, seed=5, max_depth=-1, sampler="independent",
                          rr_depth=1000)
    assert_pixel_means(img, LE)


def test_scattering_furnace_fails_without_the_medium_inside():
    # Negative control: the same sphere with an absorbing, scattering medium (albedo 0.6) is visibly darker than
    # Le; the furnace comparison above would catch a medium that lost energy.
    medium = {"sigma_t": [0.5, 1.0, 1.5], "albedo": 0.6}
    img = caustica.render(medium_sphere(medium), spp=64, seed=2, max_depth=-1)
    m, se = mean_and_se(img[..., 2])
    assert LE[2] - m > 20 * se


def test_truncated_depth_keeps_single_scattering():
    # max_depth 2 in a scattering medium: the camera segment plus one more, i.e. the light seen straight
    # through the medium and single scattering by NEE (no MIS partner beyond it): between Le exp(-sigma R) and Le.
    medium = {"sigma_a": 0.0, "sigma_s": 1.0, "g": 0.3}
    one = caustica.render(medium_sphere(medium), spp=64, seed=3, max_depth=1)
    two = caustica.render(medium_sphere(medium), spp=64, seed=3, max_depth=2)
    full = caustica.render(medium_sphere(medium), spp=64, seed=3, max_depth=-1)
    m1, se1 = mean_and_se(one[..., 0])
    m2, _ = mean_and_se(two[..., 0])
    mf, _ = mean_and_se(full[..., 0])
    assert abs(m1 - LE[0] * np.exp(-R)) < 4 * se1, (m1, se1)
    assert m1 < m2 < mf


def glass_sphere(absorption=None, medium=None):
    glass = {"type": "dielectric", "eta": 1.5}
    if absorption is not None:
        glass["absorption"] = absorption
    d = {
        "camera": {"position": [0, 0.3, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 30,
                   "width": 32, "height": 32},
        "materials": {"glass": glass},
        "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1.0, "material": "glass"}],
        "lights": [{"type": "environment", "radiance": LE}],
    }
    if medium is not None:
        d["media"] = {"inside": medium}
        d["shapes"][0]["interior"] = "inside"
    return d


def test_medium_inside_glass_matches_beer_lambert_absorption():
    # The material's absorption (applied to segments that end on the glass's back side) and an absorbing
    # medium behind the same glass describe one light transport: the two images agree region by region.
    sa = [0.3, 0.8, 1.6]
    a = caustica.render(glass_sphere(absorption=sa), spp=128, seed=4, max_depth=-1)
    b = caustica.render(glass_sphere(medium={"sigma_a": sa, "sigma_s": 0.0}), spp=128, seed=5, max_depth=-1)
    # 4 x 4 regions of 8 x 8 pixels, per channel: the difference of the region means within 4.5 standard
    # errors of that difference (48 comparisons).
    worst = 0.0
    for y in range(0, 32, 8):
        for x in range(0, 32, 8):
            for c in range(3):
                ma, sea = mean_and_se(a[y:y + 8, x:x + 8, c])
                mb, seb = mean_and_se(b[y:y + 8, x:x + 8, c])
                se = np.hypot(sea, seb)
                if se == 0.0:
                    assert ma == mb
                    continue
                worst = max(worst, abs(ma - mb) / se)
    assert worst < 4.5, worst
    # The medium is really there: the glass without it is brighter in the centre.
    clear = caustica.render(glass_sphere(), spp=16, seed=4, max_depth=-1)
    assert clear[12:20, 12:20, 2].mean() > 1.5 * b[12:20, 12:20, 2].mean()


def test_reflection_at_a_boundary_enters_the_side_it_leaves_on():
    # A mirror whose front (exterior) side is declared to hold an absorbing medium, seen by a camera in vacuum:
    # the reflected ray leaves on the exterior side, so it travels in the absorber and never reaches the sky
    # (pbrt-v4's GetMedium, Mitsuba's target_medium); around the mirror the sky is seen through vacuum.
    d = {
        "camera": {"position": [0, 0, 5], "target": [0, 0, 0], "fov": 40, "width": 16, "height": 16},
        "media": {"ink": {"sigma_a": 5.0, "sigma_s": 0.0}},
        "materials": {"mirror": {"type": "conductor"}},
        "shapes": [{"type": "rectangle", "material": "mirror", "exterior": "ink",
                    "transform": {"rotate": {"axis": [0, 1, 0], "angle": 20}}}],
        "lights": [{"type": "environment", "radiance": LE}],
    }
    img = caustica.render(d, spp=4, seed=1, max_depth=-1)
    assert float(img[8, 8].max()) == 0.0  # the mirror's centre
    assert np.allclose(img[0, 0], LE)     # the corner: the sky
    # Without the declared medium the mirror shows the sky.
    del d["shapes"][0]["exterior"]
    assert np.allclose(caustica.render(d, spp=4, seed=1, max_depth=-1)[8, 8], LE, rtol=1e-4)


def test_wavefront_and_threads_give_the_same_image():
    medium = {"sigma_a": 0.1, "sigma_s": [0.5, 1.0, 1.5], "g": 0.5}
    scene = medium_sphere(medium, width=16)
    ref = caustica.render(scene, spp=8, seed=6, max_depth=-1, threads=1)
    assert np.array_equal(ref, caustica.render(scene, spp=8, seed=6, max_depth=-1, threads=2))
    # The wavefront driver runs the same stages (the shadow stage through null surfaces): the same image.
    wf = caustica.render(scene, spp=8, seed=6, max_depth=-1, wavefront=True)
    assert np.array_equal(ref, wf)


def test_every_integrator_renders_media():
    # No integrator refuses participating media since upg gathers in them (upg.h): a small fog sphere
    # renders finite and non-black with each.
    scene = medium_sphere({"sigma_a": 0.1, "sigma_s": 0.5}, width=8)
    for integrator in caustica.integrators():
        img = caustica.render(scene, integrator=integrator, spp=2, photons=500, seed=1)
        assert np.isfinite(img).all() and img.mean() > 0, integrator


def test_cli_refusal_in_media_exits_with_code_2(tmp_path):
    # An integrator that cannot render the scene's emissive medium (light tracing: its camera paths end at the
    # first non-delta vertex) is an input error: exit code 2, one line, no image.
    f = tmp_path / "fog.json"
    f.write_text(json.dumps(medium_sphere({"sigma_a": 0.1, "sigma_s": 0.5, "emission": 1.0}, width=8)))
    r = subprocess.run([sys.executable, "-m", "caustica", "render", str(f), "--integrator", "light", "--spp", "1",
                        "-o", str(tmp_path / "out.exr")], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert "does not render emissive media" in r.stderr
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "out.exr").exists()


@pytest.mark.parametrize("edit,message", [
    (lambda d: d["shapes"][0].update(interior="smoke"),
     "/shapes/0/interior: no medium named 'smoke' in /media (media: m)"),
    (lambda d: d["camera"].update(medium="smoke"), "/camera/medium: no medium named 'smoke' in /media (media: m)"),
    (lambda d: d["media"]["m"].update(albedo=0.5), "/media/m: give sigma_a and sigma_s, or sigma_t and albedo, not both pairs"),
    (lambda d: d["media"]["m"].update(g=1.0), "/media/m/g: expected a number in (-1, 1)"),
    (lambda d: d["media"]["m"].update(type="grid"), "/media/m/type: unknown medium type 'grid' (allowed: homogeneous, heterogeneous)"),
    (lambda d: d["media"]["m"].update(type="heterogeneous"), "/media/m: a heterogeneous medium needs \"density\" (a grid)"),
    (lambda d: d["media"]["m"].update(density={"file": "x.vol"}), "/media/m/density: unknown key (allowed: type, sigma_a, sigma_s, sigma_t, albedo, scale, g, emission)"),
    (lambda d: d["media"]["m"].update(sigma_a=-1.0), "/media/m/sigma_a: expected non-negative colour values"),
    (lambda d: d["materials"]["boundary"].update(eta=1.5), "/materials/boundary/eta: unknown key (allowed: type)"),
])
def test_json_errors_name_the_path(edit, message):
    d = medium_sphere({"sigma_a": 0.1, "sigma_s": 0.5})
    edit(d)
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(d)
    assert str(e.value) == "<dict>: " + message


def test_sigma_t_albedo_scale_and_export_round_trip(tmp_path):
    # sigma_t / albedo / scale (Mitsuba's parameters) is the same medium as sigma_a / sigma_s.
    a = medium_sphere({"sigma_t": [1.0, 2.0, 4.0], "albedo": [0.5, 0.75, 1.0], "scale": 0.5, "g": 0.2}, width=12)
    b = medium_sphere({"sigma_a": [0.25, 0.25, 0.0], "sigma_s": [0.25, 0.75, 2.0], "g": 0.2}, width=12)
    assert caustica.describe(a)["media"] == 1
    ia = caustica.render(a, spp=4, seed=7, max_depth=-1)
    assert np.array_equal(ia, caustica.render(b, spp=4, seed=7, max_depth=-1))
    # Exported and read back: the media, the interfaces, the camera's medium and the null material survive.
    out = tmp_path / "fog.json"
    caustica.export_scene(a, out)
    j = json.loads(out.read_text())
    assert j["media"]["m"]["sigma_s"] == [0.25, 0.75, 2.0]
    assert j["shapes"][0]["interior"] == "m" and j["shapes"][0]["exterior"] is None
    assert j["camera"]["medium"] == "m"
    assert j["materials"]["boundary"] == {"type": "null"}
    assert np.array_equal(ia, caustica.render(str(out), spp=4, seed=7, max_depth=-1))
    # The exported file and the scene-format example follow the JSON Schema; a misspelt medium key does not.
    schema = json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))
    jsonschema.Draft202012Validator(schema).validate(j)
    jsonschema.Draft202012Validator(schema).validate(a)
    bad = json.loads(json.dumps(a))
    bad["media"]["m"]["sigma"] = 1.0
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.Draft202012Validator(schema).validate(bad)


MITSUBA_FOG = """<scene version="3.0.0">
  <integrator type="volpath"><integer name="max_depth" value="-1"/></integrator>
  <medium type="homogeneous" id="fog">
    <rgb name="sigma_t" value="1, 2, 4"/>
    <rgb name="albedo" value="0.5, 0.75, 1"/>
    <float name="scale" value="0.5"/>
    <phase type="hg"><float name="g" value="0.2"/></phase>
  </medium>
  <sensor type="perspective">
    <float name="fov" value="100"/>
    <transform name="to_world"><lookat origin="0, 0, 0" target="0.3, 0.2, -1" up="0, 1, 0"/></transform>
    <ref id="fog"/>
    <film type="hdrfilm"><integer name="width" value="12"/><integer name="height" value="12"/></film>
  </sensor>
  <shape type="sphere">
    <float name="radius" value="2"/>
    <bsdf type="null"/>
    <ref name="interior" id="fog"/>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="1, 0.5, 2"/></emitter>
</scene>
"""


def test_mitsuba_homogeneous_medium_null_bsdf_and_sensor_medium(tmp_path):
    f = tmp_path / "fog.xml"
    f.write_text(MITSUBA_FOG)
    out = tmp_path / "fog.json"
    caustica.export_scene(str(f), out)
    j = json.loads(out.read_text())
    (name, m), = j["media"].items()
    assert m["sigma_a"] == pytest.approx([0.25, 0.25, 0.0]) and m["sigma_s"] == pytest.approx([0.25, 0.75, 2.0])
    assert m["g"] == pytest.approx(0.2)
    assert j["shapes"][0]["interior"] == name and j["shapes"][0]["exterior"] is None
    assert j["materials"][j["shapes"][0]["material"]] == {"type": "null"}
    cam = j["camera"] if isinstance(j["camera"], dict) else j["cameras"][j["camera"]]
    assert cam["medium"] == name
    # And it renders the albedo-1 channel of the furnace: blue is Le.
    img = caustica.render(str(f), spp=32, seed=1)
    m_b, se_b = mean_and_se(img[..., 2])
    assert abs(m_b - 2.0) < 4 * se_b, (m_b, se_b)


@pytest.mark.parametrize("xml,message", [
    ('<medium type="grid" id="x"/>', 'unsupported medium type (supported: homogeneous, heterogeneous)'),
    ('<medium type="heterogeneous" id="x"><volume name="sigma_t" type="gridvolume"/></medium>',
     'a gridvolume needs a filename (a .vol file)'),
    ('<medium type="homogeneous" id="x"><volume name="sigma_t" type="gridvolume"/></medium>',
     'unsupported volume here (supported: constvolume; a gridvolume only as a heterogeneous medium\'s sigma_t '
     'or a medium\'s albedo)'),
    ('<medium type="homogeneous" id="x"><phase type="rayleigh"/></medium>',
     'unsupported phase function (supported: isotropic, hg)'),
    ('<medium type="homogeneous" id="x"><rgb name="albedo" value="1.5"/></medium>', 'expected an albedo in [0, 1]'),
    ('<shape type="sphere"><ref name="interior" id="nope"/></shape>', "no medium with id 'nope' is defined before this line"),
])
def test_mitsuba_medium_errors(tmp_path, xml, message):
    f = tmp_path / "bad.xml"
    f.write_text(f'<scene version="3.0.0">\n{xml}\n</scene>\n')
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(str(f))
    assert str(e.value).startswith(f"{f}:") and str(e.value).endswith(message), str(e.value)


def test_builtin_fog_scene():
    # smallvcm-fog: smallvcm-spheres with haze inside the box. The haze scatters light into the view of the
    # dark opening's border and dims the walls; the same seed without the haze is another image. path and the
    # photon mappers render it (test_media_photons.py, test_media_ppm.py), and so does every other integrator.
    assert caustica.describe("smallvcm-fog")["media"] == 1
    fog = caustica.render(caustica.load_scene("smallvcm-fog", width=32, height=32), spp=16, seed=1)
    clear = caustica.render(caustica.load_scene("smallvcm-spheres", width=32, height=32), spp=16, seed=1)
    assert np.isfinite(fog).all() and fog.mean() > 0
    assert np.abs(fog - clear).mean() > 0.05 * clear.mean()
    upg = caustica.render(caustica.load_scene("smallvcm-fog", width=32, height=32), integrator="upg", spp=4, seed=1)
    assert np.isfinite(upg).all() and upg.mean() > 0



def single_scattering_reference(d, c, I, sigma_a, sigma_s, g, n=20000, density=None, depth=None):
    """Single scattering of a point light at c (intensity I) into the ray from the origin along unit d, in an
    infinite homogeneous medium: int_0^inf sigma_s p(-d . wi) I exp(-sigma_t (t + r)) / r^2 dt with r the
    distance from x(t) to c; with t = delta + D tan(theta), dt / r^2 = dtheta / D (midpoint rule in theta).
    For a heterogeneous medium, density(x) gives the density at the points x (m x 3) and depth(x, t, r) the
    optical depth per unit sigma_t from the origin to x plus from x to c (t + r above)."""
    sigma_a, sigma_s = np.broadcast_to(sigma_a, 3), np.broadcast_to(sigma_s, 3)
    st = sigma_a + sigma_s
    delta = float(np.dot(c, d))
    D = float(np.linalg.norm(c - delta * d))
    ta, tb = np.arctan2(-delta, D), np.pi / 2
    th = ta + (np.arange(n) + 0.5) / n * (tb - ta)
    t = delta + D * np.tan(th)
    x = t[:, None] * d[None, :]
    wi = c[None, :] - x
    r = np.linalg.norm(wi, axis=1)
    cos = -(wi @ d) / r
    phase = (1 - g * g) / (4 * np.pi * (1 + g * g + 2 * g * cos) ** 1.5)
    if density is not None:
        phase = phase * density(x)
    tau = t + r if depth is None else depth(x, t, r)
    f = phase[:, None] * np.exp(-np.outer(tau, st)) * sigma_s[None, :] * np.asarray(I)[None, :] / D
    return f.sum(axis=0) * (tb - ta) / n


def pixel_centre_directions(W, fov=60.0):
    """(y, x, unit direction) of the W x W pixel centres of a camera at the origin looking along -z, y up, x
    right, `fov` degrees on its (square) image."""
    tan_half = np.tan(np.radians(fov / 2))
    for y in range(W):
        for x in range(W):
            dd = np.array([(2 * (x + 0.5) / W - 1) * tan_half, (1 - 2 * (y + 0.5) / W) * tan_half, -1.0])
            yield y, x, dd / np.linalg.norm(dd)


def worst_region_z(imgs, ref, block=4):
    """The largest |mean deviation| / standard error over block x block regions and channels of renders
    `imgs` (seeds x H x W x 3, independent pixels) against `ref` (H x W x 3)."""
    dev = imgs - ref[None]
    worst = 0.0
    for by in range(0, ref.shape[0], block):
        for bx in range(0, ref.shape[1], block):
            for ch in range(3):
                m, se = mean_and_se(dev[:, by:by + block, bx:bx + block, ch])
                worst = max(worst, abs(m) / se)
    return worst


@pytest.mark.parametrize("light", ["point", "spot"])
def test_single_scattering_of_a_point_light_matches_quadrature(light):
    # A camera inside an infinite medium with a point (or wide spot) light in view, max_depth 2: every pixel is
    # the single-scattering integral along its centre ray (no jitter), estimated by free-flight sampling with
    # NEE and by equiangular sampling, combined by MIS (integrator/path.h). 16 x 16 pixels, 8 seeds.
    sa, ss, g, I = 0.1, [0.3, 0.5, 0.8], 0.5, [5.0, 4.0, 3.0]
    c = np.array([0.3, 0.2, -2.0])
    W = 16
    lamp = {"type": "point", "position": c.tolist(), "intensity": I}
    if light == "spot":  # pointing at the camera, wide enough to cover the view
        lamp = {"type": "spot", "position": c.tolist(), "target": [0, 0, 0], "intensity": I, "cutoff_angle": 170,
                "falloff_start": 170}
    d = {
        "camera": {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov": 60, "width": W, "height": W,
                   "medium": "fog"},
        "media": {"fog": {"sigma_a": sa, "sigma_s": ss, "g": g}},
        "materials": {"black": {"type": "diffuse", "reflectance": 0.0}},
        "shapes": [{"type": "sphere", "center": [0, 0, 50], "radius": 0.1, "material": "black"}],
        "lights": [lamp],
    }
    imgs = np.stack([caustica.render(d, spp=64, seed=s, max_depth=2, jitter=False) for s in range(8)])
    # Reference per pixel centre: the camera's directions (fov 60 on the smaller axis, y up, x right).
    ref = np.zeros((W, W, 3))
    for y, x, dd in pixel_centre_directions(W):
        ref[y, x] = single_scattering_reference(dd, c, I, sa, ss, g)
    # The phase function matters here: the isotropic answer is far off.
    iso = single_scattering_reference(np.array([0, 0, -1.0]), c, I, sa, ss, 0.0)
    assert np.all(np.abs(iso - ref[W // 2, W // 2]) > 0.1 * ref[W // 2, W // 2])
    # 4 x 4 regions x 3 channels, 128 independent estimates each: within 4 standard errors.
    worst = worst_region_z(imgs, ref)
    assert worst < 4.0, worst
    # And the estimate is sharp: the image's relative error is a few percent at 64 spp.
    assert np.abs(imgs.mean(axis=0) - ref).mean() < 0.05 * ref.mean()
