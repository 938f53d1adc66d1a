"""Colour density grids and albedo grids in heterogeneous media (medium/medium_grid.h, Medium::albedo_grid).

Analytic answers: a pure absorber whose colour density varies along the view (every pixel is
Le_c exp(-sigma_c int d_c), per channel), also as sigma_t with an albedo grid of zeros; the albedo-1 furnace
with a random colour grid and an albedo grid of ones (Le everywhere). Cross-checks: a colour grid k_c d(x)
with sigma_t 1 is the one-channel grid d(x) with sigma_t k; an albedo grid split in two halves is the same
smoke as two media with constant albedos, one inside a box that covers the grid's half (path tracer per
region, pppm and sppm per image; with a negative control, the albedos swapped). Formats: inline values,
NumPy arrays, .vol files of three channels, export, Mitsuba XML (a colour sigma_t gridvolume, an albedo
gridvolume with its own to_world, and a homogeneous medium with an albedo gridvolume), the JSON Schema and
the errors."""
import json
import os
import struct

import numpy as np
import pytest

import caustica
from test_media import LE, assert_pixel_means, medium_sphere
from test_media_grid import (CUDA, MITSUBA_BOX, ROW, WHY, assert_cuda_matches_cpu, blob, cli_render_error,
                             grid_medium, load_error, random_grid, slab)
from test_media_photons import fog_box, region_means

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def colour_grid(values):
    """A {resolution, values, channels} grid object from an array indexed [z, y, x, c]."""
    nz, ny, nx, c = values.shape
    return {"resolution": [nx, ny, nz], "channels": c, "values": values.ravel().tolist()}


def write_vol(path, values):
    """Mitsuba's .vol layout (volume_io.h) for an array indexed [z, y, x] or [z, y, x, c]."""
    v = values if values.ndim == 4 else values[..., None]
    nz, ny, nx, c = v.shape
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]) + struct.pack("<5i", 1, nx, ny, nz, c) + struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        f.write(v.astype("<f4").tobytes())


# Per channel, densities along the view (a different profile in each).
ROWS = np.stack([np.asarray(ROW, np.float32), np.asarray(ROW[::-1], np.float32),
                 np.asarray(ROW, np.float32) * 0.5 + 0.4], axis=-1)  # [x, c]


@pytest.mark.parametrize("integrator", ["path", "pppm"])
@pytest.mark.parametrize("form", ["sigma_a", "albedo grid of zeros"])
def test_colour_absorber_is_beer_lambert_along_the_view(integrator, form):
    # The slab of test_media_grid.py with a colour density: channel c of every pixel is
    # Le_c exp(-sigma_c 2 mean(row_c)) (the interpolant's integral over the width 2). As sigma_t with an albedo
    # grid of zeros the medium is the same absorber (sigma_s(x) = 0 sigma_t(x)); were the albedo grid ignored,
    # the constants (albedo 1 there) would make it a pure scatterer. 4 standard errors of the 256-pixel mean.
    s = np.array([0.3, 0.6, 1.0])
    scene = slab(ROW, s.tolist())
    m = scene["media"]["m"]
    m["density"] = colour_grid(ROWS.reshape(1, 1, len(ROW), 3))
    if form != "sigma_a":
        del m["sigma_a"], m["sigma_s"]
        m["sigma_t"] = s.tolist()
        m["albedo"] = {"resolution": [2, 1, 1], "values": [0.0, 0.0]}
    opts = {"photons": 1000} if integrator == "pppm" else {}
    img = caustica.render(scene, integrator=integrator, spp=64, seed=1, max_depth=-1, **opts)
    expected = np.array(LE) * np.exp(-s * 2.0 * ROWS.mean(axis=0))
    assert_pixel_means(img, expected)


def test_furnace_with_a_colour_grid_and_an_albedo_grid_of_ones():
    # Albedo 1 everywhere (an albedo grid of ones, 3 x 2 x 2, its own box larger than the density's) in a
    # random colour grid with empty cells, sigma_t coloured, g 0.3: Le in every pixel whatever the densities.
    # 4 standard errors of the 576-pixel mean.
    values = np.random.default_rng(3).uniform(0.0, 2.0, size=(6, 6, 6, 3)).astype(np.float32)
    values[::3, ::2, 1::4, 1] = 0.0
    medium = grid_medium(values[..., 0], sigma_t=[0.8, 1.0, 1.25], g=0.3)
    medium["density"] = colour_grid(values)
    medium["albedo"] = {"resolution": [3, 2, 2], "channels": 3, "values": [1.0] * 36,
                        "bounds": [[-3, -3, -3], [3, 3, 3]]}
    img = caustica.render(medium_sphere(medium), spp=64, seed=2, max_depth=-1)
    assert_pixel_means(img, LE)


def test_colour_grid_is_the_coloured_coefficients():
    # A colour grid k_c d(x) with sigma_t 1 and a constant albedo grid 0.7 is the one-channel grid d(x) with
    # sigma_t k and albedo 0.7: the same medium, sampled differently (the colour grid's majorant is its
    # largest channel's). Path tracer, per channel over 4 seeds each, within 4 standard errors of the
    # difference.
    d = random_grid(6, seed=4)
    k = np.array([0.6, 1.0, 1.5], np.float32)
    one = grid_medium(d, sigma_t=k.tolist(), albedo=0.7, g=0.2)
    col = grid_medium(d, sigma_t=1.0, g=0.2)
    col["density"] = colour_grid(d[..., None] * k)
    col["albedo"] = {"resolution": [1, 1, 1], "values": [0.7]}
    a = np.array([caustica.render(medium_sphere(one, width=16), spp=32, seed=s, max_depth=-1)
                  .reshape(-1, 3).mean(axis=0) for s in range(4)])
    b = np.array([caustica.render(medium_sphere(col, width=16), spp=32, seed=s + 10, max_depth=-1)
                  .reshape(-1, 3).mean(axis=0) for s in range(4)])
    se = np.sqrt(a.var(axis=0, ddof=1) / 4 + b.var(axis=0, ddof=1) / 4)
    assert (se > 0).all()
    assert (np.abs(a.mean(axis=0) - b.mean(axis=0)) < 4 * se).all(), (a.mean(0), b.mean(0), se)


ALBEDO_LEFT, ALBEDO_RIGHT = [0.9, 0.5, 0.2], [0.3, 0.8, 0.95]


def split_smoke(two_media, swap=False, width=32):
    """test_media_photons.fog_box's point light in a colour smoke blob (density over [-1.8, 1.8]^3, 0 outside)
    whose albedo is ALBEDO_LEFT for x < 0 and ALBEDO_RIGHT for x > 0: as one medium with a 2 x 1 x 1 nearest
    albedo grid, or (two_media) as two media with constant albedos, the right one inside a null box
    [0, 1.85] x [-1.85, 1.85]^2 (exterior: the left one) that covers the grid's right half; `swap` exchanges
    the two media's albedos (the negative control)."""
    s = fog_box(light=(-0.4, 1.2, 0.0), width=width)
    dens = blob(12)[..., None] * np.array([1.0, 0.7, 0.45], np.float32)
    base = {"type": "heterogeneous", "sigma_t": 0.45, "g": 0.3, "density": colour_grid(dens),
            "bounds": [[-1.8, -1.8, -1.8], [1.8, 1.8, 1.8]]}
    if not two_media:
        s["media"]["fog"] = dict(base, albedo={"resolution": [2, 1, 1], "channels": 3,
                                               "values": ALBEDO_LEFT + ALBEDO_RIGHT, "filter": "nearest",
                                               "outside": "clamp"})
        return s
    left, right = (ALBEDO_RIGHT, ALBEDO_LEFT) if swap else (ALBEDO_LEFT, ALBEDO_RIGHT)
    s["media"] = {"fog": dict(base, albedo=left), "right": dict(base, albedo=right)}
    s["shapes"].append({"type": "cube", "material": "fog", "interior": "right", "exterior": "fog",
                        "transform": {"scale": [0.925, 1.85, 1.85], "translate": [0.925, 0, 0]}})
    return s


def region_stats(a, b):
    """Per 8 x 8 region of two independent renders of one scene (independent pixels): the mean of both and
    the standard error of that mean (half their difference has its noise; its spread over the region's 64
    pixels)."""
    m = 0.5 * (a.astype(np.float64) + b)
    H = a.shape[0] // 4
    se = (0.5 * (a.astype(np.float64) - b)).reshape(4, H, 4, H, 3).std(axis=(1, 3), ddof=1) / H
    return region_means(m), se


def test_albedo_grid_is_two_media_with_constant_albedos():
    # The path tracer per 8 x 8 region (48 comparisons with channels): the albedo grid within 4.5 standard
    # errors of the two media (false alarms about 3e-4 for all 48 together); with the albedos swapped in the
    # two-media scene (negative control) some region is more than 8 standard errors off.
    kw = dict(spp=256, max_depth=-1)
    mg, sg = region_stats(*(caustica.render(split_smoke(False), seed=k, **kw) for k in (1, 2)))
    m2, s2 = region_stats(*(caustica.render(split_smoke(True), seed=k, **kw) for k in (3, 4)))
    z = np.abs(mg - m2) / np.sqrt(sg ** 2 + s2 ** 2)
    assert z.max() < 4.5, (z.max(), mg[..., 2], m2[..., 2])
    mw, sw = region_stats(*(caustica.render(split_smoke(True, swap=True), seed=k, **kw) for k in (5, 6)))
    assert (np.abs(mg - mw) / np.sqrt(sg ** 2 + sw ** 2)).max() > 8.0


@pytest.mark.parametrize("integrator", ["pppm", "sppm"])
def test_photon_mapping_takes_the_albedo_grid(integrator):
    # The same two scenes in the photon mappers (volume photons carry sigma_s(x) = albedo(x) sigma_t(x) in
    # their power): the same kernels on the same photon distribution, so the images agree within noise. Photons
    # are shared between pixels: per channel, image means over 4 seeds each, within 4 standard errors of the
    # difference.
    kw = dict(integrator=integrator, spp=8, photons=20000, max_depth=-1)
    a = np.array([caustica.render(split_smoke(False, width=16), seed=k, **kw).reshape(-1, 3).mean(axis=0)
                  for k in range(4)])
    b = np.array([caustica.render(split_smoke(True, width=16), seed=k + 10, **kw).reshape(-1, 3).mean(axis=0)
                  for k in range(4)])
    se = np.sqrt(a.var(axis=0, ddof=1) / 4 + b.var(axis=0, ddof=1) / 4)
    assert (se > 0).all()
    assert (np.abs(a.mean(axis=0) - b.mean(axis=0)) < 4 * se).all(), (a.mean(0), b.mean(0), se)


def test_numpy_arrays_give_channels(tmp_path):
    # From Python a grid may be a 4D NumPy array [z, y, x, c]: resolution and channels come from its shape;
    # the same image as the flat list, and as a three-channel .vol file.
    dens = blob(8)[..., None] * np.array([1.0, 0.6, 0.3], np.float32)
    alb = np.random.default_rng(5).uniform(0.2, 1.0, size=(2, 3, 4, 3)).astype(np.float32)
    flat = fog_box(width=8)
    flat["media"]["fog"] = {"type": "heterogeneous", "sigma_t": 0.5, "density": colour_grid(dens),
                            "albedo": colour_grid(alb), "bounds": [[-2, -2, -2], [2, 2, 2]]}
    arr = fog_box(width=8)
    arr["media"]["fog"] = dict(flat["media"]["fog"], density={"values": dens}, albedo={"values": alb})
    kw = dict(spp=2, seed=5, max_depth=-1)
    ref = caustica.render(flat, **kw)
    assert ref.mean() > 0 and np.array_equal(ref, caustica.render(arr, **kw))
    write_vol(tmp_path / "d.vol", dens)
    write_vol(tmp_path / "a.vol", alb)
    files = json.loads(json.dumps(flat))
    files["media"]["fog"].update(density={"file": "d.vol"}, albedo={"file": "a.vol"})
    (tmp_path / "s.json").write_text(json.dumps(files))
    assert np.array_equal(ref, caustica.render(str(tmp_path / "s.json"), **kw))


def test_export_keeps_channels_and_the_albedo_grids_placement(tmp_path):
    # Export writes both grids as .vol files (three channels stay three), sigma_t and the albedo grid, and
    # the albedo grid's own transform, filter and outside where they differ from the density grid's; the
    # exported scene renders the same image.
    s = split_smoke(False, width=8)
    s["media"]["fog"]["albedo"]["transform"] = {"scale": 3, "translate": [-1.5, -1.5, -1.5]}
    del s["media"]["fog"]["albedo"]["outside"]
    caustica.export_scene(s, str(tmp_path / "e.json"))
    m = json.loads((tmp_path / "e.json").read_text())["media"]["fog"]
    assert m["density"] == {"file": "e.grid0.vol"} and m["type"] == "heterogeneous"
    assert m["albedo"]["file"] == "e.grid1.vol" and m["albedo"]["filter"] == "nearest"
    assert "outside" not in m["albedo"] and "sigma_a" not in m
    np.testing.assert_allclose(m["sigma_t"], [0.45] * 3, rtol=1e-6)
    np.testing.assert_allclose(m["albedo"]["transform"]["matrix"], [3, 0, 0, -1.5, 0, 3, 0, -1.5, 0, 0, 3, -1.5])
    head = (tmp_path / "e.grid0.vol").read_bytes()[:48]
    assert struct.unpack("<5i", head[4:24]) == (1, 12, 12, 12, 3)
    kw = dict(spp=4, seed=2, max_depth=-1)
    np.testing.assert_allclose(caustica.render(str(tmp_path / "e.json"), **kw), caustica.render(s, **kw),
                               rtol=1e-5, atol=1e-7)




def test_mitsuba_colour_sigma_t_and_albedo_gridvolumes(tmp_path):
    # Mitsuba 3's heterogeneous medium with a three-channel sigma_t gridvolume and an albedo gridvolume placed
    # by its own to_world: caustica reads sigma_t (the grid times scale), the albedo grid and both placements,
    # as export shows, and renders the scene as its export renders it.
    dens = blob(8)[..., None] * np.array([1.0, 0.6, 0.3], np.float32)
    alb = np.random.default_rng(6).uniform(0.1, 1.0, size=(2, 2, 2, 3)).astype(np.float32)
    write_vol(tmp_path / "d.vol", dens)
    write_vol(tmp_path / "a.vol", alb)
    medium = """<medium type="heterogeneous" id="smoke">
    <volume name="sigma_t" type="gridvolume"><string name="filename" value="d.vol"/>
      <transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform></volume>
    <volume name="albedo" type="gridvolume"><string name="filename" value="a.vol"/>
      <string name="filter_type" value="nearest"/>
      <transform name="to_world"><scale value="1.5"/><translate value="-0.5, -1, -1"/></transform></volume>
    <float name="scale" value="2"/>
    <boolean name="has_spectral_extinction" value="true"/>
  </medium>"""
    (tmp_path / "s.xml").write_text(MITSUBA_BOX.format(medium=medium))
    caustica.export_scene(str(tmp_path / "s.xml"), str(tmp_path / "x.json"))
    m = json.loads((tmp_path / "x.json").read_text())["media"]["smoke"]
    np.testing.assert_allclose(m["sigma_t"], [2, 2, 2])
    np.testing.assert_allclose(m["transform"]["matrix"], [2, 0, 0, -1, 0, 2, 0, -1, 0, 0, 2, -1], atol=1e-6)
    np.testing.assert_allclose(m["albedo"]["transform"]["matrix"], [1.5, 0, 0, -0.5, 0, 1.5, 0, -1, 0, 0, 1.5, -1],
                               atol=1e-6)
    assert m["outside"] == "clamp" and m["albedo"]["filter"] == "nearest"
    assert (tmp_path / "x.grid0.vol").read_bytes()[48:] == dens.astype("<f4").tobytes()
    assert (tmp_path / "x.grid1.vol").read_bytes()[48:] == alb.astype("<f4").tobytes()
    kw = dict(spp=8, seed=1, max_depth=-1)
    a = caustica.render(str(tmp_path / "s.xml"), **kw)
    assert a.mean() > 0
    np.testing.assert_allclose(a, caustica.render(str(tmp_path / "x.json"), **kw), rtol=1e-5, atol=1e-7)


def test_mitsuba_homogeneous_medium_with_an_albedo_gridvolume(tmp_path):
    # Mitsuba 3's homogeneous medium takes its albedo as a volume too: caustica makes it a grid medium of
    # constant density (a clamped 1 x 1 x 1 grid of 1) with the albedo grid; it renders as the JSON medium
    # written that way does (4 seeds each, per channel, 4 standard errors of the difference).
    alb = np.array([0.2, 0.9], np.float32).reshape(1, 1, 2)
    write_vol(tmp_path / "a.vol", alb)
    medium = """<medium type="homogeneous" id="smoke">
    <rgb name="sigma_t" value="1.5, 1, 0.5"/>
    <volume name="albedo" type="gridvolume"><string name="filename" value="a.vol"/>
      <transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform></volume>
  </medium>"""
    (tmp_path / "s.xml").write_text(MITSUBA_BOX.format(medium=medium))
    assert caustica.describe(str(tmp_path / "s.xml"))["heterogeneous_media"] == 1
    js = {
        "camera": {"position": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "width": 16,
                   "height": 16},
        "media": {"smoke": {"type": "heterogeneous", "sigma_t": [1.5, 1, 0.5], "outside": "clamp",
                            "density": {"resolution": [1, 1, 1], "values": [1.0]},
                            "albedo": {"resolution": [2, 1, 1], "values": [0.2, 0.9],
                                       "bounds": [[-1, -1, -1], [1, 1, 1]]}}},
        "materials": {"b": {"type": "null"}},
        "shapes": [{"type": "cube", "material": "b", "interior": "smoke"}],
        "lights": [{"type": "environment", "radiance": [1, 0.5, 2]}],
    }
    a = np.array([caustica.render(str(tmp_path / "s.xml"), spp=16, seed=k).reshape(-1, 3).mean(axis=0)
                  for k in range(4)])
    b = np.array([caustica.render(js, spp=16, seed=k + 10, max_depth=-1).reshape(-1, 3).mean(axis=0)
                  for k in range(4)])
    se = np.sqrt(a.var(axis=0, ddof=1) / 4 + b.var(axis=0, ddof=1) / 4)
    assert (np.abs(a.mean(axis=0) - b.mean(axis=0)) < 4 * se).all(), (a.mean(0), b.mean(0), se)


@pytest.mark.parametrize("edit,message", [
    (lambda m: m["density"].update(channels=2), "/media/m/density/channels: expected 1 or 3"),
    (lambda m: m["density"].update(channels=3),
     "/media/m/density/values: expected 192 numbers (4 x 4 x 4 x 3 channels), got 64"),
    (lambda m: m.update(albedo={"resolution": [1, 1, 2], "values": [0.5, 1.5]}),
     "/media/m/albedo/values/1: expected an albedo in [0, 1]"),
    (lambda m: m.update(albedo={"resolution": [1, 1, 1], "values": [0.5], "bounds": [[0, 0, 0], [1, 1, 1]],
                                "transform": {"scale": 2}}),
     "/media/m/albedo: give \"bounds\" or \"transform\", not both"),
    (lambda m: m.update(albedo={"resolution": [1, 1, 1], "values": [0.5], "filter": "cubic"}),
     "/media/m/albedo/filter: unknown filter 'cubic' (allowed: trilinear, nearest)"),
    (lambda m: (m.clear(), m.update(sigma_t=1.0, albedo={"resolution": [1, 1, 1], "values": [0.5]})),
     "/media/m/albedo: an albedo grid needs \"type\": \"heterogeneous\""),
    (lambda m: m.update(sigma_a=0.1, albedo={"resolution": [1, 1, 1], "values": [0.5]}),
     "/media/m: give sigma_a and sigma_s, or sigma_t and albedo, not both pairs"),
])
def test_json_errors_name_the_path(edit, message):
    medium = grid_medium(random_grid(4), sigma_t=1.0)
    edit(medium)
    assert message in load_error(medium)


def test_albedo_file_above_one_is_a_one_line_error(tmp_path):
    write_vol(tmp_path / "a.vol", np.array([0.5, 1.25], np.float32).reshape(1, 1, 2))
    medium = {"type": "heterogeneous", "sigma_t": 1.0, "density": {"resolution": [1, 1, 1], "values": [1.0]},
              "albedo": {"file": "a.vol"}}
    line = cli_render_error(tmp_path, medium_sphere(medium))
    assert "s.json: /media/m/albedo/file:" in line, line
    assert "sample 1 is 1.250000 (expected an albedo in [0, 1])" in line, line
    # The same file in Mitsuba XML: the line names the XML file and the volume.
    xml = MITSUBA_BOX.format(medium="""<medium type="heterogeneous" id="smoke">
    <volume name="albedo" type="gridvolume"><string name="filename" value="a.vol"/></volume></medium>""")
    (tmp_path / "s.xml").write_text(xml)
    with pytest.raises(caustica.SceneError) as e:
        caustica.load_scene(str(tmp_path / "s.xml"))
    assert "s.xml" in str(e.value) and "(expected an albedo in [0, 1])" in str(e.value)


def test_schema_takes_colour_and_albedo_grids(tmp_path):
    import jsonschema
    schema = json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))
    v = jsonschema.Draft202012Validator(schema)
    s = split_smoke(False, width=8)
    v.validate(s)
    caustica.export_scene(s, str(tmp_path / "e.json"))
    v.validate(json.loads((tmp_path / "e.json").read_text()))
    bad = json.loads(json.dumps(s))
    bad["media"]["fog"]["density"]["channels"] = 2
    with pytest.raises(jsonschema.ValidationError):
        v.validate(bad)
    homogeneous = {"sigma_t": 1.0, "albedo": {"resolution": [1, 1, 1], "values": [0.5]}}
    with pytest.raises(jsonschema.ValidationError):
        v.validate(dict(s, media={"fog": homogeneous}))


def test_threads_and_wavefront_give_the_same_image():
    s = split_smoke(False, width=16)
    one = caustica.render(s, spp=4, seed=6, max_depth=-1, threads=1)
    assert np.array_equal(one, caustica.render(s, spp=4, seed=6, max_depth=-1, threads=2))
    assert np.array_equal(one, caustica.render(s, spp=4, seed=6, max_depth=-1, wavefront=True))


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
def test_cuda_matches_the_cpu():
    # The path tracer and sppm in the split smoke (colour grid, albedo grid), per region against the CPU.
    assert_cuda_matches_cpu(split_smoke(False), (dict(spp=64), dict(integrator="sppm", spp=16, photons=20000)))
