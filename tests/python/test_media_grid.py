"""Heterogeneous media: density grids (medium/medium_grid.h) in the path tracer and in pppm.

Analytic answers: a pure absorber whose density varies along the view seen by an orthographic camera (every
pixel is Le exp(-sigma_a int d), and the integral of a cell-centred trilinear row over the cube is the mean of
its samples times the length), and the albedo-1 furnace of test_media.py with a random grid (radiance is
Le everywhere whatever the density). Cross-checks: a grid of constant density against the homogeneous medium
it equals, pppm against the path tracer in a smoke blob lit by a point light. Formats: inline values and a
Mitsuba .vol file give the same image, export writes the grid beside the JSON and reads back the same,
Mitsuba XML's heterogeneous medium with a gridvolume, and the errors."""
import json
import os
import struct
import subprocess
import sys

import numpy as np
import pytest

import caustica
from conftest import mean_and_se, relmse
from test_media import (LE, assert_pixel_means, medium_sphere, pixel_centre_directions,
                        single_scattering_reference, worst_region_z)
from test_media_photons import fog_box, region_means

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def random_grid(n=8, seed=1, hi=2.0):
    return np.random.default_rng(seed).uniform(0.0, hi, size=(n, n, n)).astype(np.float32)


def grid_medium(values, bounds=((-2, -2, -2), (2, 2, 2)), **coeffs):
    """A heterogeneous medium over `bounds` with density `values` (indexed [z, y, x])."""
    nz, ny, nx = values.shape
    m = {"type": "heterogeneous", "density": {"resolution": [nx, ny, nz], "values": values.ravel().tolist()},
         "bounds": [list(bounds[0]), list(bounds[1])]}
    m.update(coeffs)
    return m


def load_error(medium):
    """The one-line SceneError that loading test_media.medium_sphere(medium) raises."""
    with pytest.raises(caustica.SceneError) as e:
        caustica.load_dict(medium_sphere(medium))
    return str(e.value)


def cli_render_error(tmp_path, scene):
    """Renders `scene` (a dict, written as s.json) with the CLI, which must fail with exit code 2, one line on
    stderr, no traceback and no image; returns the line."""
    (tmp_path / "s.json").write_text(json.dumps(scene))
    r = subprocess.run([sys.executable, "-m", "caustica", "render", str(tmp_path / "s.json"), "--spp", "1",
                        "-o", str(tmp_path / "o.exr")], capture_output=True, text=True)
    line = r.stderr.strip()
    assert r.returncode == 2 and "\n" not in line and "Traceback" not in r.stderr, r.stderr
    assert not (tmp_path / "o.exr").exists()
    return line


# A Mitsuba scene around a medium `{medium}` (its id "smoke"): a null cube filled with it under a constant sky,
# seen from (0, 0, 5) at 16 x 16.
MITSUBA_BOX = """<scene version="3.0.0">
  <integrator type="volpath"><integer name="max_depth" value="-1"/></integrator>
  <sensor type="perspective">
    <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="1, 0.5, 2"/></emitter>
  {medium}
  <shape type="cube"><bsdf type="null"/><ref name="interior" id="smoke"/></shape>
</scene>
"""


def write_vol(path, values):
    """Mitsuba's .vol layout (volume_io.h): header, then float32 samples x fastest."""
    nz, ny, nx = values.shape
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]) + struct.pack("<5i", 1, nx, ny, nz, 1) + struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        f.write(values.astype("<f4").tobytes())


# Densities along the view; the ends weigh in the convention (below).
ROW = [2.5, 0.2, 1.5, 0.0, 0.6, 0.9, 0.1, 2.0]


def slab(row, sigma_a, width=16):
    """An orthographic camera looking along +x through a null cube [-1, 1]^3 of a pure absorber whose density
    varies along x only (`row`), under a constant environment."""
    n = len(row)
    values = np.tile(np.asarray(row, np.float32), (1, 1, 1)).reshape(1, 1, n)
    return {
        "camera": {"type": "orthographic", "position": [-3, 0, 0], "target": [0, 0, 0], "up": [0, 1, 0],
                   "view_size": 1.5, "width": width, "height": width},
        "media": {"m": grid_medium(values, bounds=((-1, -1, -1), (1, 1, 1)), sigma_a=sigma_a, sigma_s=0.0)},
        "materials": {"b": {"type": "null"}},
        "shapes": [{"type": "cube", "material": "b", "interior": "m"}],
        "lights": [{"type": "environment", "radiance": LE}],
    }


@pytest.mark.parametrize("integrator", ["path", "pppm"])
def test_absorbing_grid_is_beer_lambert_along_the_view(integrator):
    row = ROW
    sa = np.array([0.3, 0.6, 1.0])
    opts = {"photons": 1000} if integrator == "pppm" else {}
    img = caustica.render(slab(row, sa.tolist()), integrator=integrator, spp=64, seed=1, max_depth=-1, **opts)
    # The interpolant's integral over the cube's width 2 is 2 mean(row) (flat half-cells at the ends).
    expected = np.array(LE) * np.exp(-sa * 2.0 * np.mean(row))
    # 4 standard errors of the 256-pixel mean (pixels are independent: no photons are involved).
    assert_pixel_means(img, expected)


def test_absorbing_grid_fails_with_the_wrong_convention():
    # Negative control: samples at the cell corners (i / (n - 1)) instead of their centres would make the
    # integral the trapezoid rule's, (sum - (first + last) / 2) / (n - 1) = 0.79 instead of 0.975 here, a
    # difference the test above resolves (blue: 0.41 against 0.28, standard error ~0.005 at 64 spp).
    row = ROW
    img = caustica.render(slab(row, [0.3, 0.6, 1.0]), spp=64, seed=1, max_depth=-1)
    corner = LE[2] * np.exp(-1.0 * 2.0 * (sum(row) - (row[0] + row[-1]) / 2) / (len(row) - 1))
    m, se = mean_and_se(img[..., 2])
    assert abs(m - corner) > 8 * se, (m, corner, se)


@pytest.mark.parametrize("sampler", ["sobol", "independent"])
def test_scattering_furnace(sampler):
    # Albedo 1 (sigma_s differs per channel, so the hero channel's delta tracking and the spectral MIS over
    # the path are both exercised) in a random 8^3 grid with empty cells, g 0.3: Le in every pixel. NEE from
    # the scattering events reaches the environment through the grid by ratio tracking. Measured over 8
    # seeds (sobol): z within +-2.3. 4 standard errors of the 576-pixel mean.
    values = random_grid()
    values[::3, ::2, 1::4] = 0.0
    medium = grid_medium(values, sigma_a=0.0, sigma_s=[0.8, 1.0, 1.25], g=0.3)
    img = caustica.render(medium_sphere(medium), spp=64, seed=2, max_depth=-1, sampler=sampler)
    assert_pixel_means(img, LE)


def test_constant_grid_equals_the_homogeneous_medium():
    # A grid of density 0.5 with sigma 2x the homogeneous medium's is that medium: the path tracer's image
    # means over 4 seeds agree within 4 standard errors of their difference, per channel; so do pppm's (the
    # same photon paths in distribution, its kernels' bias shared).
    hom = {"sigma_a": 0.1, "sigma_s": [0.6, 0.8, 1.0], "g": 0.4}
    het = grid_medium(np.full((2, 3, 4), 0.5, np.float32), sigma_a=0.2, sigma_s=[1.2, 1.6, 2.0], g=0.4)
    for integrator, opts in (("path", dict(spp=32)), ("pppm", dict(spp=8, photons=5000))):
        a = np.array([caustica.render(medium_sphere(hom, width=16), integrator=integrator, seed=s, max_depth=-1,
                                      **opts).reshape(-1, 3).mean(axis=0) for s in range(4)])
        b = np.array([caustica.render(medium_sphere(het, width=16), integrator=integrator, seed=s, max_depth=-1,
                                      **opts).reshape(-1, 3).mean(axis=0) for s in range(4)])
        se = np.sqrt(a.var(axis=0, ddof=1) / 4 + b.var(axis=0, ddof=1) / 4)
        assert (se > 0).all()
        assert (np.abs(a.mean(axis=0) - b.mean(axis=0)) < 4 * se).all(), (integrator, a.mean(0), b.mean(0), se)


def blob(n=16):
    """A smoke blob: a Gaussian lump off the centre over a rippled haze, densities 0 to 3.6, indexed [z, y, x]."""
    c = (np.arange(n) + 0.5) / n * 2 - 1
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    d = 3.0 * np.exp(-((x - 0.2) ** 2 + (y + 0.1) ** 2 + z ** 2) / 0.3) + 0.3 * (1 + np.sin(5 * x) * np.cos(4 * y + 1))
    return d.astype(np.float32)


def smoke_box(width=32):
    """test_media_photons.fog_box with the fog a heterogeneous blob (sigma_s 0.4, sigma_a 0.02 per density)."""
    d = fog_box(width=width)
    d["media"]["fog"] = grid_medium(blob(), sigma_a=0.02, sigma_s=0.4, g=0.3)
    return d


@pytest.fixture(scope="module")
def smoke_reference():
    # The path tracer's reference: two halves of 2048 spp (their difference gives its standard error per
    # 8 x 8 region).
    a, b = (caustica.render(smoke_box(), spp=2048, seed=k, max_depth=-1).astype(np.float64) for k in (11, 12))
    return 0.5 * (a + b), (0.5 * (a - b)).reshape(4, 8, 4, 8, 3).std(axis=(1, 3), ddof=1) / 8


@pytest.mark.parametrize("integrator", ["pppm", "sppm"])
def test_photon_mapping_cross_checks_the_path_tracer_in_smoke(smoke_reference, integrator):
    # A point light in the smoke blob over a diffuse floor: single and multiple scattering in a heterogeneous
    # medium. The photon mapper's error falls from 4 to 64 passes (measured relMSE 0.066 -> 0.0084 for pppm,
    # 0.066 -> 0.0086 for sppm), and per region the means over 4 seeds of 64 passes agree with the reference
    # within 5 standard errors plus 2% of the value for the kernels' bias at the automatic radii (measured
    # -2.6% to +3.9% for pppm, -2.1% to +4.2% for sppm, at most 2.4 standard errors). A density lost or
    # counted twice (sigma_s(x) in the photons' power and not the camera's weight) would be off by far more.
    s = smoke_box()
    ref, se_r = smoke_reference
    e = {p: relmse(caustica.render(s, integrator=integrator, spp=p, photons=20000, seed=5, max_depth=-1), ref)
         for p in (4, 64)}
    assert e[64] < 0.5 * e[4], e
    runs = np.array([region_means(caustica.render(s, integrator=integrator, spp=64, photons=20000, seed=k,
                                                  max_depth=-1)) for k in range(4)])
    m, se_p, r = runs.mean(axis=0), runs.std(axis=0, ddof=1) / 2, region_means(ref)
    z = np.abs(m - r) / (5 * np.sqrt(se_p ** 2 + se_r ** 2) + 0.02 * r)
    assert z.max() < 1.0, (z.max(), m[..., 1], r[..., 1])


def test_threads_and_wavefront_give_the_same_image():
    s = smoke_box(width=16)
    one = caustica.render(s, spp=8, seed=6, max_depth=-1, threads=1)
    assert np.array_equal(one, caustica.render(s, spp=8, seed=6, max_depth=-1, threads=2))
    # The wavefront runs the same stage functions with the same streams.
    assert np.array_equal(one, caustica.render(s, spp=8, seed=6, max_depth=-1, wavefront=True))
    kw = dict(integrator="pppm", spp=3, seed=4, photons=5000, max_depth=-1)
    ref = caustica.render(s, threads=1, **kw)
    assert np.array_equal(ref, caustica.render(s, threads=2, **kw))
    np.testing.assert_allclose(caustica.render(s, wavefront=True, **kw), ref, rtol=1e-5, atol=1e-9)


CUDA, WHY = caustica.cuda_status()


def assert_cuda_matches_cpu(scene, runs):
    """On a GPU: each render_job keyword set of `runs` on `scene`, per 8 x 8 region, against the CPU over 4
    seeds: the same streams, so the difference is rounding and the paths it diverts; its spread gives the
    standard error (5 of them), plus 0.1% of the value for the rounding itself."""
    for kw in runs:
        cpu = np.array([region_means(caustica.render(scene, seed=k, max_depth=-1, **kw)) for k in range(4)])
        gpu = np.array([region_means(caustica.render(scene, seed=k, max_depth=-1, device="cuda", **kw))
                        for k in range(4)])
        d = gpu - cpu
        assert (np.abs(d.mean(axis=0)) < 5 * d.std(axis=0, ddof=1) / 2 + 1e-3 * np.abs(cpu.mean(axis=0))).all()


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
def test_cuda_matches_the_cpu():
    # The path tracer and pppm in the smoke blob.
    assert_cuda_matches_cpu(smoke_box(), (dict(spp=64), dict(integrator="pppm", spp=16, photons=20000)))


def test_vol_file_equals_inline_values_and_export_round_trips(tmp_path):
    values = blob(8)
    inline = smoke_box(width=16)
    inline["media"]["fog"] = grid_medium(values, sigma_a=0.02, sigma_s=0.4, g=0.3)
    write_vol(tmp_path / "smoke.vol", values)
    from_file = json.loads(json.dumps(inline))
    from_file["media"]["fog"]["density"] = {"file": "smoke.vol"}
    (tmp_path / "scene.json").write_text(json.dumps(from_file))
    kw = dict(spp=4, seed=3, max_depth=-1)
    a = caustica.render(inline, **kw)
    b = caustica.render(str(tmp_path / "scene.json"), **kw)
    assert a.mean() > 0 and np.array_equal(a, b)
    # Export writes the grid as <stem>.grid0.vol beside the JSON; the scene reads back the same.
    caustica.export_scene(inline, str(tmp_path / "out.json"))
    out = json.loads((tmp_path / "out.json").read_text())
    m = out["media"]["fog"]
    assert m["type"] == "heterogeneous" and m["density"] == {"file": "out.grid0.vol"}
    assert (tmp_path / "out.grid0.vol").read_bytes()[48:] == values.astype("<f4").tobytes()
    assert np.array_equal(a, caustica.render(str(tmp_path / "out.json"), **kw))


def test_mitsuba_heterogeneous_gridvolume(tmp_path):
    # Mitsuba 3's heterogeneous medium: sigma_t a gridvolume (its unit cube placed by to_world) times scale,
    # a constant albedo; caustica maps it to sigma_s = albedo scale, sigma_a = (1 - albedo) scale per unit
    # density, the grid clamped at its border as Mitsuba's default wrap mode does, and renders like the JSON
    # scene with the same grid.
    # Dense in one quadrant (x low, y high), so that a grid mirrored or turned renders differently (measured:
    # 17 to 34 standard errors in some region).
    values = np.full((8, 8, 8), 0.2, np.float32)
    values[:, 4:, :4] = 3.0
    write_vol(tmp_path / "smoke.vol", values)
    xml = MITSUBA_BOX.format(medium="""<medium type="heterogeneous" id="smoke">
    <volume name="sigma_t" type="gridvolume">
      <string name="filename" value="smoke.vol"/>
      <transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform>
    </volume>
    <rgb name="albedo" value="0.9, 0.8, 0.7"/>
    <float name="scale" value="1.5"/>
    <phase type="hg"><float name="g" value="0.3"/></phase>
  </medium>""")
    (tmp_path / "smoke.xml").write_text(xml)
    caustica.export_scene(str(tmp_path / "smoke.xml"), str(tmp_path / "x.json"))
    m = json.loads((tmp_path / "x.json").read_text())["media"]["smoke"]
    assert m["type"] == "heterogeneous" and m["outside"] == "clamp"
    np.testing.assert_allclose(m["sigma_s"], [1.35, 1.2, 1.05], rtol=1e-6)
    np.testing.assert_allclose(m["sigma_a"], [0.15, 0.3, 0.45], rtol=1e-5)
    np.testing.assert_allclose(m["transform"]["matrix"], [2, 0, 0, -1, 0, 2, 0, -1, 0, 0, 2, -1], atol=1e-6)
    assert (tmp_path / "x.grid0.vol").read_bytes()[48:] == values.astype("<f4").tobytes()
    img = caustica.render(str(tmp_path / "smoke.xml"), spp=64, seed=1)
    js = {
        "camera": {"position": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "width": 16,
                   "height": 16},
        "media": {"smoke": grid_medium(values, bounds=((-1, -1, -1), (1, 1, 1)), sigma_a=[0.15, 0.3, 0.45],
                                       sigma_s=[1.35, 1.2, 1.05], g=0.3, outside="clamp")},
        "materials": {"b": {"type": "null"}},
        "shapes": [{"type": "cube", "material": "b", "interior": "smoke"}],
        "lights": [{"type": "environment", "radiance": [1, 0.5, 2]}],
    }
    ref = caustica.render(js, spp=64, seed=2, max_depth=-1)
    # Independent pixels: per 4 x 4 region, the two renders' means within 4 standard errors of their
    # difference.
    def stats(im):
        r = im.reshape(4, 4, 4, 4, 3).transpose(0, 2, 1, 3, 4).reshape(4, 4, 16, 3)
        return r.mean(axis=2), r.std(axis=2, ddof=1) / 4
    (ma, sa), (mb, sb) = stats(img.astype(np.float64)), stats(ref.astype(np.float64))
    assert (np.abs(ma - mb) < 4 * np.sqrt(sa ** 2 + sb ** 2) + 1e-6).all()
    assert ma.min() < 0.8 * ma.max()  # the blob's shadow: the comparison has something to see


@pytest.mark.parametrize("edit,message", [
    (lambda m: m["density"].update(values=[1.0]), "/media/m/density/values: expected 64 numbers (4 x 4 x 4), got 1"),
    (lambda m: m["density"]["values"].__setitem__(3, -1.0), "/media/m/density/values/3: expected a density >= 0"),
    (lambda m: m["density"].update(resolution=[4, 4]), "/media/m/density/resolution: expected [nx, ny, nz]"),
    (lambda m: m["density"].update(file="a.vol"),
     "/media/m/density: give \"file\", or \"resolution\" and \"values\", not both"),
    (lambda m: m.update(transform={"scale": 2}), "/media/m: give \"bounds\" or \"transform\", not both"),
    (lambda m: m.update(bounds=[[0, 0, 0], [1, -1, 1]]),
     "/media/m/bounds: expected the second corner above the first on every axis"),
    (lambda m: m.update(filter="cubic"), "/media/m/filter: unknown filter 'cubic' (allowed: trilinear, nearest)"),
    (lambda m: m.update(outside="repeat"), "/media/m/outside: unknown value 'repeat' (allowed: zero, clamp)"),
    (lambda m: m.update(density={"file": "missing.vol"}), "missing.vol': cannot open the file"),
])
def test_json_errors_name_the_path(edit, message):
    medium = grid_medium(random_grid(4), sigma_a=0.1, sigma_s=0.5)
    edit(medium)
    assert message in load_error(medium)


@pytest.mark.parametrize("blob_bytes,message", [
    (b"VOX" + bytes(45), "not a Mitsuba volume file"),
    (b"VOL" + bytes([3]) + struct.pack("<5i", 2, 1, 1, 1, 1) + bytes(24) + bytes(4), "encoding 2 (expected 1, float32)"),
    (b"VOL" + bytes([3]) + struct.pack("<5i", 1, 2, 1, 1, 2) + bytes(24) + bytes(16),
     "2 channels (expected 1, a density, or 3, a colour grid)"),
    (b"VOL" + bytes([3]) + struct.pack("<5i", 1, 2, 1, 1, 3) + bytes(24) + bytes(8),
     "expected 72 bytes for 2 x 1 x 1 samples of 3 channels, the file has 56"),
    (b"VOL" + bytes([3]) + struct.pack("<5i", 1, 2, 2, 1, 1) + bytes(24) + bytes(12),
     "expected 64 bytes for 2 x 2 x 1 samples, the file has 60"),
    (b"VOL" + bytes([3]) + struct.pack("<5i", 1, 1, 1, 1, 1) + bytes(24) + struct.pack("<f", -2.0),
     "sample 0 is -2.000000 (expected finite values >= 0)"),
])
def test_bad_vol_files_are_one_line_errors(tmp_path, blob_bytes, message):
    (tmp_path / "g.vol").write_bytes(blob_bytes)
    medium = {"type": "heterogeneous", "sigma_t": 1.0, "density": {"file": "g.vol"}}
    line = cli_render_error(tmp_path, medium_sphere(medium))
    assert "s.json: /media/m/density/file: density grid '" in line and message in line, line


def test_schema_takes_grid_media(tmp_path):
    import jsonschema
    schema = json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))
    v = jsonschema.Draft202012Validator(schema)
    scene = smoke_box(width=8)
    v.validate(scene)
    caustica.export_scene(scene, str(tmp_path / "e.json"))
    v.validate(json.loads((tmp_path / "e.json").read_text()))
    bad = json.loads(json.dumps(scene))
    del bad["media"]["fog"]["density"]
    with pytest.raises(jsonschema.ValidationError):
        v.validate(bad)
    homogeneous_with_grid = json.loads(json.dumps(scene))
    del homogeneous_with_grid["media"]["fog"]["type"]
    with pytest.raises(jsonschema.ValidationError):
        v.validate(homogeneous_with_grid)


def test_describe_and_info_count_grid_media(tmp_path):
    d = caustica.describe(smoke_box(width=8))
    assert d["media"] == 1 and d["heterogeneous_media"] == 1
    (tmp_path / "s.json").write_text(json.dumps(smoke_box(width=8)))
    r = subprocess.run([sys.executable, "-m", "caustica", "info", str(tmp_path / "s.json")], capture_output=True,
                       text=True)
    assert r.returncode == 0 and "media:       1 (1 heterogeneous)" in r.stdout, r.stdout


def test_builtin_smallvcm_smoke(tmp_path):
    # The built-in smoke plume: one heterogeneous medium. Exported (the grid as a .vol file beside the JSON)
    # it renders the same image; with the smoke's coefficients set to 0 it is SmallVCM's empty box, and the
    # plume's pixels (rows 8-17, columns 12-19 of 32: the column's upper half in front of the back wall) are
    # brighter than the empty box's: the smoke scatters the ceiling light towards the camera (measured +0.197
    # over 0.155, 38 standard errors). 4 seeds of 32 spp; 6 standard errors of the difference.
    assert caustica.describe("smallvcm-smoke")["heterogeneous_media"] == 1
    s = caustica.load_scene("smallvcm-smoke", width=32, height=32)
    assert s.integrator_defaults.get("integrator") in (None, "path")
    caustica.export_scene(s, str(tmp_path / "smoke.json"))
    d = json.loads((tmp_path / "smoke.json").read_text())
    assert d["media"]["smoke"]["density"] == {"file": "smoke.grid0.vol"}
    a = caustica.render(s, spp=4, seed=1)
    assert np.allclose(a, caustica.render(str(tmp_path / "smoke.json"), spp=4, seed=1), rtol=1e-5, atol=1e-6)
    d["media"]["smoke"]["sigma_s"] = d["media"]["smoke"]["sigma_a"] = 0.0
    (tmp_path / "empty.json").write_text(json.dumps(d))
    diffs = []
    for seed in range(4):
        smoke = caustica.render(s, spp=32, seed=seed)
        empty = caustica.render(str(tmp_path / "empty.json"), spp=32, seed=seed + 10)
        assert np.isfinite(smoke).all()
        diffs.append(smoke[8:18, 12:20].mean() - empty[8:18, 12:20].mean())
    m, se = mean_and_se(np.array(diffs))
    assert m > 6 * se, (m, se)
    # pppm renders it too (volume photons in the grid).
    img = caustica.render(s, integrator="pppm", spp=2, photons=5000, seed=1)
    assert np.isfinite(img).all() and img.mean() > 0


def test_numpy_density_in_a_dict():
    # From Python the density can be a 3D NumPy array indexed [z, y, x]: its resolution is read from the
    # shape and its samples raveled (x fastest), giving the same image as the flat list.
    values = blob(8)[:, :6, :]  # 8 x 6 x 8: z, y, x
    flat = smoke_box(width=8)
    flat["media"]["fog"] = grid_medium(values, sigma_a=0.02, sigma_s=np.float32(0.4), g=0.3)
    arr = smoke_box(width=8)
    arr["media"]["fog"] = {"type": "heterogeneous", "sigma_a": 0.02, "sigma_s": 0.4, "g": 0.3,
                           "density": {"values": values}, "bounds": [[-2, -2, -2], [2, 2, 2]]}
    assert flat["media"]["fog"]["density"]["resolution"] == [8, 6, 8]
    kw = dict(spp=2, seed=5, max_depth=-1)
    assert np.array_equal(caustica.render(flat, **kw), caustica.render(arr, **kw))
    assert isinstance(arr["media"]["fog"]["density"]["values"], np.ndarray)  # the caller's dict is unchanged


def test_single_scattering_in_a_grid_matches_quadrature():
    # Equiangular sampling of a point light in a grid medium, combined with free-flight NEE by MIS weights
    # over a proxy of the free-flight density (integrator/path.h), with ratio tracking's transmittance to the
    # equiangular point: a camera in an infinite medium whose density varies along z only (a clamped 1D grid
    # over z in [-3, 1], constant beyond), the light in view, max_depth 2 (single scattering), pixel centres.
    # Reference per pixel: the single-scattering integral by quadrature, the optical depths from the
    # antiderivative of the density along z (exact for the piecewise-linear interpolant). 16 x 16 pixels, 8
    # seeds; per 4 x 4 region and channel within 4 standard errors.
    sa, ss, g, I = 0.1, [0.3, 0.5, 0.8], 0.5, [5.0, 4.0, 3.0]
    row = np.array([0.2, 1.8, 0.6, 2.4, 0.1, 1.2, 0.9, 0.4], np.float32)  # density along z (sample 0 at z = -3)
    c = np.array([0.3, 0.2, -2.0])
    W = 16
    medium = {"type": "heterogeneous", "sigma_a": sa, "sigma_s": ss, "g": g, "outside": "clamp",
              "density": {"resolution": [1, 1, len(row)], "values": row.tolist()},
              "bounds": [[-1, -1, -3], [1, 1, 1]]}
    d = {
        "camera": {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov": 60, "width": W, "height": W,
                   "medium": "fog"},
        "media": {"fog": medium},
        "materials": {"black": {"type": "diffuse", "reflectance": 0.0}},
        "shapes": [{"type": "sphere", "center": [0, 0, 50], "radius": 0.1, "material": "black"}],
        "lights": [{"type": "point", "position": c.tolist(), "intensity": I}],
    }
    imgs = np.stack([caustica.render(d, spp=64, seed=s, max_depth=2, jitter=False) for s in range(8)])
    def reference(row):
        # The density along z: cell-centred samples over [-3, 1], held beyond the outermost centres; its
        # antiderivative F on a fine grid (linear beyond it, where the density is constant).
        n = len(row)
        zf = np.linspace(-400.0, 10.0, 800001)
        dens = np.interp(zf, -3.0 + (np.arange(n) + 0.5) * 4.0 / n, row)
        F = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(zf))])

        def along(za, zb, length):  # optical depth per unit sigma_t along segments from z = za to zb
            dz = np.abs(zb - za)
            flat = dz < 1e-9
            step = np.abs(np.interp(zb, zf, F) - np.interp(za, zf, F)) * length / np.where(flat, 1.0, dz)
            return np.where(flat, length * np.interp(za, zf, dens), step)

        def depth(x, t, r):  # camera to x, then x to the light
            return along(np.zeros_like(t), x[:, 2], t) + along(x[:, 2], np.full_like(t, c[2]), r)

        ref = np.zeros((W, W, 3))
        for y, x, dd in pixel_centre_directions(W):
            ref[y, x] = single_scattering_reference(dd, c, I, sa, ss, g, n=4000, depth=depth,
                                                    density=lambda p: np.interp(p[:, 2], zf, dens))
        return ref

    ref = reference(row)
    assert worst_region_z(imgs, ref) < 4.0, worst_region_z(imgs, ref)  # measured 1.8
    # Negative control: the reference of the grid turned upside down is far off (measured 21 standard errors).
    assert worst_region_z(imgs, reference(row[::-1].copy())) > 8.0
    # And sharp: the image's relative error is a few percent at 64 spp (measured 3.4%).
    err = np.abs(imgs.mean(axis=0) - ref).mean()
    assert err < 0.05 * ref.mean(), (err, ref.mean())
