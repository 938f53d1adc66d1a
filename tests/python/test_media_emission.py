"""Emissive participating media (medium/medium.h, Medium::Le and emission_grid): the path tracer's collision
estimator of the emission sigma_a Le.

Analytic answers: a camera at the centre of a null sphere of radius R filled with an absorbing emitter under a
constant environment (every pixel is Le (1 - e^{-sigma_a R}) + L_env e^{-sigma_a R}, any max_depth); the
furnace with emission (a scattering, absorbing medium emitting the environment's radiance: L_env everywhere),
homogeneous and as a colour grid with an emission grid; an orthographic view through an absorbing grid whose
density and emission vary along the view (1D quadrature). Also: pm, pppm and sppm refuse emissive media, threads
and the CPU wavefront give the same image, export, the schema, describe/info and the errors."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import caustica
from conftest import mean_and_se
from test_media import LE, R, assert_pixel_means, medium_sphere
from test_media_grid import ROW, grid_medium, load_error, random_grid, slab

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.mark.parametrize("max_depth", [1, -1])
@pytest.mark.parametrize("wavefront", [False, True])
def test_absorbing_emitter(max_depth, wavefront):
    # Radiance emitted along the view and the environment behind, both through the absorber; a pure absorber
    # has no scattered light, so max_depth 1 (the camera segment only) gives the same. Were the emission scored
    # with sigma_t instead of sigma_a (or at every event without its weight) the red channel would be off by
    # far more than the 4 standard errors of the 576-pixel mean.
    sa = np.array([0.2, 0.5, 1.0])
    le = np.array([3.0, 0.0, 1.5])
    medium = {"sigma_a": sa.tolist(), "sigma_s": 0.0, "emission": le.tolist()}
    img = caustica.render(medium_sphere(medium), spp=64, seed=1, max_depth=max_depth, wavefront=wavefront)
    T = np.exp(-sa * R)
    assert_pixel_means(img, le * (1 - T) + np.array(LE) * T)


def emission_furnace_medium(kind):
    """A medium that emits the environment's radiance L_env and scatters (albedo < 1, chromatic, g 0.4): in
    equilibrium with it, sigma_a L_env emitted + sigma_s L_env scattered in = sigma_t L_env lost. The grid
    version: a random colour density, an albedo grid, and Le times an emission grid equal to L_env everywhere."""
    if kind == "homogeneous":
        return {"sigma_a": [0.3, 0.1, 0.6], "sigma_s": [0.5, 1.0, 0.4], "g": 0.4, "emission": LE}
    d = np.random.default_rng(7).uniform(0.0, 2.0, size=(5, 5, 5, 3)).astype(np.float32)
    medium = grid_medium(d[..., 0], sigma_t=[0.8, 1.1, 1.0], g=0.4)
    medium["density"] = {"resolution": [5, 5, 5], "channels": 3, "values": d.ravel().tolist()}
    medium["albedo"] = {"resolution": [2, 1, 1], "channels": 3, "values": [0.9, 0.2, 0.5, 0.3, 0.7, 0.95]}
    medium["emission"] = {"resolution": [1, 1, 1], "channels": 3, "values": LE, "outside": "clamp"}
    return medium


@pytest.mark.parametrize("kind", ["homogeneous", "colour grid with an emission grid"])
def test_furnace_with_emission(kind):
    # emission_furnace_medium is in equilibrium with the environment: every pixel is L_env. 4 standard errors
    # of the 576-pixel mean.
    img = caustica.render(medium_sphere(emission_furnace_medium(kind)), spp=64, seed=2, max_depth=-1)
    assert_pixel_means(img, LE)


def test_emission_grid_along_the_view_matches_quadrature():
    # The orthographic slab of test_media_grid.py (a pure absorber whose density varies along x over the cube
    # [-1, 1]^3, the environment behind it) emitting a colour emission grid that varies along x too,
    # Le(x) = E(x) le: each pixel is int sigma_a d(x) Le(x) exp(-sigma_a int_{-1}^x d) dx +
    # L_env exp(-sigma_a int d), the interpolants cell-centred and held to the faces. 4 standard errors of the
    # 256-pixel mean.
    sa = np.array([0.3, 0.6, 1.0])
    le = np.array([2.0, 1.0, 0.5])
    erow = np.array([0.0, 1.0, 3.0, 2.0, 0.5])
    s = slab(ROW, sa.tolist())
    s["media"]["m"]["emission"] = {"resolution": [len(erow), 1, 1], "channels": 3,
                                   "values": (erow[:, None] * le).ravel().tolist()}
    img = caustica.render(s, spp=64, seed=3, max_depth=-1)
    x = np.linspace(-1.0, 1.0, 200001)

    def interp(row):
        n = len(row)
        return np.interp(x, -1.0 + (np.arange(n) + 0.5) * 2.0 / n, row)

    d, e = interp(np.asarray(ROW, np.float64)), interp(erow)
    tau = np.concatenate([[0.0], np.cumsum(0.5 * (d[1:] + d[:-1]) * np.diff(x))])  # int_{-1}^x d
    expected = []
    for c in range(3):
        f = sa[c] * d * le[c] * e * np.exp(-sa[c] * tau)
        expected.append(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x)) + LE[c] * np.exp(-sa[c] * tau[-1]))
    assert_pixel_means(img, np.array(expected))


def blackbody_rgb(kelvin):
    """scene/blackbody.h by independent numpy arithmetic: Planck's law normalized at its peak, the CIE 1931
    fit of Wyman, Sloan & Shirley 2013, XYZ / int y-bar, linear sRGB, negatives set to 0."""
    h, c, k, b = 6.62607015e-34, 299792458.0, 1.380649e-23, 2.897771955e-3
    nm = np.arange(360, 831, dtype=np.float64)
    w = np.ones_like(nm)
    w[0] = w[-1] = 0.5

    def planck(lam):
        return 2 * h * c * c / lam ** 5 / np.expm1(h * c / (lam * k * kelvin))

    def lobe(x, mu, s1, s2):
        return np.exp(-0.5 * ((x - mu) / np.where(x < mu, s1, s2)) ** 2)

    xb = 1.056 * lobe(nm, 599.8, 37.9, 31.0) + 0.362 * lobe(nm, 442.0, 16.0, 26.7) - 0.065 * lobe(nm, 501.1, 20.4, 26.2)
    yb = 0.821 * lobe(nm, 568.8, 46.9, 40.5) + 0.286 * lobe(nm, 530.9, 16.3, 31.1)
    zb = 1.217 * lobe(nm, 437.0, 11.8, 36.0) + 0.681 * lobe(nm, 459.0, 26.0, 13.8)
    spd = planck(nm * 1e-9) / planck(b / kelvin)
    xyz = np.array([np.sum(w * spd * f) for f in (xb, yb, zb)]) / np.sum(w * yb)
    m = np.array([[3.240479, -1.537150, -0.498535], [-0.969256, 1.875991, 0.041556],
                  [0.055648, -0.204043, 1.057311]])
    return np.maximum(m @ xyz, 0.0)


@pytest.mark.parametrize("kelvin", [1500.0, 3000.0, 6500.0])
def test_blackbody_emission_grid(kelvin):
    # An emission grid of temperatures ("blackbody": scale, temperature_offset, temperature_scale, pbrt-v4's
    # Lescale, temperaturecutoff and temperaturescale) in an absorbing emitter under a black sky: every pixel
    # is scale * rgb((v - offset) * temperature_scale) (1 - e^{-sigma_a R}), rgb computed here independently.
    # Within 4 standard errors of the 576-pixel mean plus 1e-3 of the value (the loader's table).
    sa = 0.8
    v = kelvin / 100.0 + 5.0  # stored as hundreds of kelvin plus an offset of 5
    medium = {"type": "heterogeneous", "sigma_a": sa, "sigma_s": 0.0, "outside": "clamp",
              "density": {"resolution": [1, 1, 1], "values": [1.0]},
              "emission": {"resolution": [2, 1, 1], "values": [v, v],
                           "blackbody": {"scale": 3.0, "temperature_offset": 5.0, "temperature_scale": 100.0}}}
    img = caustica.render(medium_sphere(medium, env=[0.0, 0.0, 0.0]), spp=32, seed=5, max_depth=-1)
    expected = 3.0 * blackbody_rgb(kelvin) * (1 - np.exp(-sa * R))
    assert expected.max() > 0
    for c in range(3):
        m, se = mean_and_se(img[..., c])
        assert abs(m - expected[c]) <= 4 * se + 1e-3 * expected.max() + 1e-9, (c, m, expected[c], se)


def test_photon_mappers_and_light_tracing_refuse_emissive_media():
    # Their paths start at lights only (light tracing's camera paths end at their first non-delta vertex).
    s = medium_sphere({"sigma_a": 0.2, "sigma_s": 0.5, "emission": 1.0})
    for integrator in ("pm", "ppm", "pppm", "sppm", "light"):
        with pytest.raises(caustica.InputError) as e:
            caustica.render(s, integrator=integrator, spp=1, photons=100)
        assert str(e.value) == (f"integrator '{integrator}' does not render emissive media (medium 'm' emits); "
                                "use --integrator path, restir, bdpt, vcm, bpm or upg")


def test_threads_wavefront_export_and_describe(tmp_path):
    d = random_grid(6, seed=9)
    medium = grid_medium(d, sigma_a=0.3, sigma_s=0.6, g=0.2)
    medium["emission"] = {"resolution": [2, 2, 1], "channels": 3, "values": [1, 0, 0, 0, 2, 0, 0, 0, 3, 1, 1, 1],
                          "transform": {"scale": 3, "translate": [-1.5, -1.5, -1.5]}}
    s = medium_sphere(medium, width=16)
    s["media"]["h"] = {"sigma_a": 0.1, "sigma_s": 0.0, "emission": [0.5, 0.25, 0.0]}
    kw = dict(spp=4, seed=6, max_depth=-1)
    one = caustica.render(s, threads=1, **kw)
    assert one.mean() > 0
    assert np.array_equal(one, caustica.render(s, threads=2, **kw))
    assert np.array_equal(one, caustica.render(s, wavefront=True, **kw))
    d_ = caustica.describe(s)
    assert d_["media"] == 2 and d_["emissive_media"] == 2 and d_["heterogeneous_media"] == 1
    caustica.export_scene(s, str(tmp_path / "e.json"))
    out = json.loads((tmp_path / "e.json").read_text())
    assert out["media"]["m"]["emission"]["file"] == "e.grid1.vol" and "transform" in out["media"]["m"]["emission"]
    np.testing.assert_allclose(out["media"]["h"]["emission"], [0.5, 0.25, 0.0])
    np.testing.assert_allclose(caustica.render(str(tmp_path / "e.json"), **kw), one, rtol=1e-5, atol=1e-7)
    import jsonschema
    schema = json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))
    v = jsonschema.Draft202012Validator(schema)
    v.validate(s)
    v.validate(out)
    with pytest.raises(jsonschema.ValidationError):
        v.validate(dict(s, media={"h": {"sigma_a": 0.1, "emission": {"resolution": [1, 1, 1], "values": [1]}}}))
    (tmp_path / "s.json").write_text(json.dumps(s))
    r = subprocess.run([sys.executable, "-m", "caustica", "info", str(tmp_path / "s.json")], capture_output=True,
                       text=True)
    assert r.returncode == 0 and "media:       2 (1 heterogeneous, 2 emissive)" in r.stdout, r.stdout


@pytest.mark.parametrize("edit,message", [
    (lambda m: m.update(emission=-1.0), "/media/m/emission"),
    (lambda m: m.update(emission={"resolution": [1, 1, 2], "values": [0.5, -1.0]}),
     "/media/m/emission/values/1: expected a radiance >= 0"),
    (lambda m: (m.clear(), m.update(sigma_a=1.0, emission={"resolution": [1, 1, 1], "values": [0.5]})),
     "/media/m/emission: an emission grid needs \"type\": \"heterogeneous\""),
    (lambda m: m.update(emission={"resolution": [1, 1, 1], "channels": 3, "values": [1, 2, 3], "blackbody": {}}),
     "/media/m/emission/blackbody: expected a grid of one channel (temperatures)"),
    (lambda m: m.update(emission={"resolution": [1, 1, 1], "values": [1], "blackbody": {"temperature_scale": 0}}),
     "/media/m/emission/blackbody/temperature_scale: expected a number > 0"),
    (lambda m: m.update(albedo={"resolution": [1, 1, 1], "values": [1], "blackbody": {}}),
     "/media/m/albedo/blackbody: unknown key (allowed: "),
])
def test_json_errors_name_the_path(edit, message):
    medium = grid_medium(random_grid(4), sigma_t=1.0)
    edit(medium)
    assert message in load_error(medium)


CUDA, WHY = caustica.cuda_status()


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
def test_cuda_matches_the_cpu():
    # On a GPU: the furnace with emission (a colour grid, an albedo grid, an emission grid) renders L_env as
    # on the CPU, and the absorbing emitter matches its analytic value.
    sa = np.array([0.2, 0.5, 1.0])
    le = np.array([3.0, 0.0, 1.5])
    img = caustica.render(medium_sphere({"sigma_a": sa.tolist(), "sigma_s": 0.0, "emission": le.tolist()}),
                          spp=64, seed=1, max_depth=-1, device="cuda")
    T = np.exp(-sa * R)
    assert_pixel_means(img, le * (1 - T) + np.array(LE) * T)
