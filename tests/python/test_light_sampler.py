"""light_sampler="bvh" (path; light/light_bvh.h): next-event estimation choosing lights by a light BVH's importance
from the shading point. The image's expectation is the power sampler's (quadrant means over independent seeds
agree within 5 standard errors, direct light and depth 5), its noise on a scene of many lights is far lower at
equal samples, the wavefront and lane-parallel drivers give the same image bit for bit, a JSON scene's
"light_sampler" and the converge variant "path+bvh" choose it, and bad options are one clear line."""
import os

import numpy as np
import pytest

import caustica
from caustica import cli
from conftest import mean_and_se, relmse

SCENE = os.path.join(os.path.dirname(__file__), "..", "data", "json", "many-lights.json")
SEEDS = 20


def quadrant_means(img):
    h, w = img.shape[0] // 2, img.shape[1] // 2
    return np.array([img[:h, :w].mean(), img[:h, w:].mean(), img[h:, :w].mean(), img[h:, w:].mean()])


def expect_same_expectation(scene, seeds=range(SEEDS), **opts):
    """Quadrant means of renders with light_sampler "power" and "bvh" over independent seeds agree within 5
    standard errors of their difference; returns the per-seed means {sampler: (seeds, 4)}."""
    per = {ls: np.array([quadrant_means(caustica.render(scene, seed=seed, light_sampler=ls, **opts))
                         for seed in seeds])
           for ls in ("power", "bvh")}
    for q in range(4):
        m_p, se_p = mean_and_se(per["power"][:, q])
        m_b, se_b = mean_and_se(per["bvh"][:, q])
        se = np.hypot(se_p, se_b)
        assert abs(m_b - m_p) <= 5 * se, (q, m_b, m_p, se)  # 5 standard errors of the difference
    return per


# Large emitters near a diffuse floor and a rough mirror: BSDF samples reach the lights often, so MIS between
# the two strategies carries weight. (With the power sampler's probabilities in the BSDF side's MIS weight and
# the BVH's in light sampling's, this scene's quadrant means are off by up to 10.6 standard errors: checked.)
LARGE = {"camera": {"position": [0, 3, 4], "target": [0, 0, 0], "width": 32, "height": 24},
         "materials": {"floor": {"type": "diffuse", "reflectance": 0.8},
                       "gloss": {"type": "conductor", "roughness": 0.2}},
         "shapes": [{"type": "rectangle", "material": "floor",
                     "transform": {"scale": 3, "rotate": {"axis": [1, 0, 0], "angle": -90}}},
                    {"type": "sphere", "center": [0.8, 0.4, 0.5], "radius": 0.4, "material": "gloss"},
                    {"type": "rectangle", "emission": [3, 3, 3],
                     "transform": {"scale": 0.6, "rotate": {"axis": [1, 0, 0], "angle": 90},
                                   "translate": [-1.2, 0.5, 0]}},
                    {"type": "rectangle", "emission": [1, 2, 4],
                     "transform": {"scale": 0.6, "rotate": {"axis": [1, 0, 0], "angle": 90},
                                   "translate": [1.2, 0.7, -0.5]}},
                    {"type": "rectangle", "emission": [8, 6, 2],
                     "transform": {"scale": 0.3, "rotate": {"axis": [1, 0, 0], "angle": 90},
                                   "translate": [0, 1.5, 1.2]}},
                    {"type": "sphere", "center": [-0.5, 0.3, 1.0], "radius": 0.15, "emission": [10, 10, 10]}]}


@pytest.mark.parametrize("max_depth", [2, 5], ids=["direct", "depth5"])
@pytest.mark.parametrize("which", ["many-lights", "large-emitters"])
def test_same_expectation_as_the_power_sampler(which, max_depth):
    scene = caustica.load_scene(SCENE) if which == "many-lights" else caustica.load_dict(LARGE)
    spp = 2 if which == "many-lights" else 4
    expect_same_expectation(scene, spp=spp, max_depth=max_depth)


@pytest.mark.parametrize("which", ["many-lights", "large-emitters"])
def test_restir_candidates_keep_the_expectation(which):
    # restir's candidates chosen by the light BVH: the same expectation as by power (temporal and spatial reuse
    # on, 2 passes, direct light and one bounce).
    scene = caustica.load_scene(SCENE, width=32, height=24) if which == "many-lights" else caustica.load_dict(LARGE)
    expect_same_expectation(scene, integrator="restir", spp=2, max_depth=3, restir_candidates=8)


@pytest.mark.parametrize("integrator, wavefront", [("sppm", False), ("sppm", True), ("pppm", False), ("pm", False),
                                                   ("ppm", False)])
def test_photon_mappers_visible_points_keep_the_expectation(integrator, wavefront):
    # The photon mappers' direct light at their visible points, its light chosen by the BVH: the same expectation
    # as by power (the photons are the same; direct light only, max_depth 2, so the difference is all NEE).
    scene = caustica.load_scene(SCENE, width=32, height=24)
    opts = dict(integrator=integrator, spp=2, max_depth=2, photons=2000)
    if integrator == "pm":
        opts["spp"] = 1
    per = expect_same_expectation(scene, wavefront=wavefront, **opts)
    assert np.std(per["bvh"][:, 0]) < np.std(per["power"][:, 0])  # and less spread between seeds


@pytest.mark.parametrize("integrator, wavefront", [("bdpt", False), ("vcm", False), ("vcm", True), ("upg", False)])
@pytest.mark.parametrize("which", ["many-lights", "large-emitters"])
def test_bidirectional_keep_the_expectation(which, integrator, wavefront):
    # bdpt, vcm and upg with next-event estimation choosing lights by the BVH while light subpaths start by power:
    # every MIS ratio between the two strategies takes each one's own pick (vcm_nee_pick). Paths of up to 3
    # segments (NEE, emitters hit, light tracing, connections and merges all weigh in). Same expectation.
    scene = caustica.load_scene(SCENE, width=32, height=24) if which == "many-lights" else caustica.load_dict(LARGE)
    opts = dict(integrator=integrator, spp=2, max_depth=3, wavefront=wavefront)
    expect_same_expectation(scene, **opts)


@pytest.mark.parametrize("integrator", ["sppm", "pppm"])
def test_photon_wavefront_gives_the_cpu_drivers_image(integrator):
    # The wavefront photon driver's visible points choose lights by the BVH as the CPU driver's do: the same
    # image to 1e-5 relative (photons summed in another order, as test_wavefront.py's comparison without it).
    scene = caustica.load_scene(SCENE, width=32, height=24)
    ref = caustica.render(scene, integrator=integrator, spp=2, seed=4, light_sampler="bvh")
    img = caustica.render(scene, integrator=integrator, spp=2, seed=4, light_sampler="bvh", wavefront=True)
    np.testing.assert_allclose(img, ref, rtol=1e-5, atol=1e-9)
    assert not np.allclose(ref, caustica.render(scene, integrator=integrator, spp=2, seed=4), rtol=1e-3)


CUDA, WHY = caustica.cuda_status()


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
@pytest.mark.parametrize("integrator", ["path", "restir", "sppm"])
def test_gpu_matches_the_cpu_per_quadrant(integrator):
    # The light BVH uploaded to the GPU: quadrant means of 12 seeds on each device within 4 combined standard
    # errors (restir without temporal reuse, so that its passes are independent).
    scene = caustica.load_scene(SCENE, width=32, height=24)
    kw = dict(integrator=integrator, spp=4, light_sampler="bvh", sampler="independent")
    if integrator == "restir":
        kw["restir_history"] = 0
    per = {d: np.array([quadrant_means(caustica.render(scene, seed=seed, device=d, **kw))
                        for seed in (range(100, 112) if d == "cpu" else range(200, 212))])
           for d in ("cpu", "cuda")}
    m_c, se_c = per["cpu"].mean(0), per["cpu"].std(0, ddof=1) / np.sqrt(12)
    m_g, se_g = per["cuda"].mean(0), per["cuda"].std(0, ddof=1) / np.sqrt(12)
    z = np.abs(m_c - m_g) / np.sqrt(se_c ** 2 + se_g ** 2)
    assert z.max() < 4.0, np.round(z, 1)


def test_less_noise_on_many_lights():
    scene = caustica.load_scene(SCENE)
    ref = caustica.render(scene, spp=2048, seed=1000)
    power = relmse(caustica.render(scene, spp=16, seed=1), ref)
    bvh = relmse(caustica.render(scene, spp=16, seed=1, light_sampler="bvh"), ref)
    # Measured 0.13 against 0.024 (scene at 64x48); the reference's own noise is in both.
    assert bvh < 0.5 * power, (bvh, power)
    # restir (no temporal reuse, 4 passes): its candidates and the indirect bounces' light samples from the BVH.
    # Measured over seeds 1-3: 0.141 by power against 0.091 by the BVH.
    power, bvh = (np.mean([relmse(caustica.render(scene, integrator="restir", spp=4, seed=seed, restir_history=0,
                                                  light_sampler=ls), ref) for seed in (1, 2, 3)])
                  for ls in ("power", "bvh"))
    assert bvh < 0.85 * power, (bvh, power)


@pytest.mark.parametrize("name", ["cornell", SCENE])
def test_wavefront_and_lanes(name):
    # The wavefront driver and the AVX2 lanes choose lights by the BVH exactly as one path at a time does.
    scene = caustica.load_scene(name, width=32, height=24)
    a = caustica.render_job(scene, spp=4, seed=3, light_sampler="bvh", lanes=False)
    b = caustica.render_job(scene, spp=4, seed=3, light_sampler="bvh", wavefront=True)
    assert np.array_equal(a.image, b.image)
    assert a.stats["lanes"] == 0
    if name != "cornell":
        return  # point, spot and environment lights: the lanes do not cover this scene
    c = caustica.render_job(scene, spp=4, seed=3, light_sampler="bvh")
    if c.stats["lanes"] == 0:
        pytest.skip("this CPU has no AVX2: the lanes do not run here")
    assert np.array_equal(a.image, c.image)


def test_errors(tmp_path, capsys):
    with pytest.raises(caustica.InputError, match="unknown light sampler 'tree' \\(allowed: power, bvh\\)"):
        caustica.render("cornell", spp=1, light_sampler="tree")
    with pytest.raises(caustica.InputError) as e:
        caustica.render("cornell", integrator="bpm", spp=1, light_sampler="bvh")
    assert str(e.value) == ("--light-sampler bvh applies to integrators path, restir, pm, ppm, sppm, pppm, bdpt, vcm, "
                            "upg, got 'bpm'")
    assert cli.main(["render", "cornell", "--light-sampler", "tree", "-o", str(tmp_path / "x.exr")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "light sampler" in err[0] and "power, bvh" in err[0], err
    out = tmp_path / "y.exr"
    assert cli.main(["render", "cornell", "--light-sampler", "bvh", "--spp", "1", "--width", "16", "--height", "16",
                     "--quiet", "-o", str(out)]) == 0
    assert out.exists()


def _scene_with(integrator_block, width=32, height=24):
    import json
    with open(SCENE) as f:
        d = json.load(f)
    d["integrator"] = integrator_block
    d["camera"].update(width=width, height=height)
    return caustica.load_dict(d, base_dir=os.path.dirname(SCENE))


def test_json_scene_option(tmp_path):
    """A JSON scene's "light_sampler" is the default of its path renders: the same image as the option given in
    Python, which overrides it; other integrators ignore it; export keeps it."""
    scene = _scene_with({"type": "path", "light_sampler": "bvh"})
    assert scene.integrator_defaults["light_sampler"] == "bvh"
    plain = _scene_with({})
    a = caustica.render(scene, spp=2, seed=3)
    b = caustica.render(plain, spp=2, seed=3, light_sampler="bvh")
    c = caustica.render(plain, spp=2, seed=3)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.array_equal(caustica.render(scene, spp=2, seed=3, light_sampler="power"), c)
    untyped = _scene_with({"light_sampler": "bvh"})  # no type: path and sppm take it, bpm renders ignore it
    assert np.array_equal(caustica.render(untyped, spp=2, seed=3), a)
    assert np.array_equal(caustica.render(untyped, integrator="sppm", spp=2, seed=3),
                          caustica.render(plain, integrator="sppm", spp=2, seed=3, light_sampler="bvh"))
    assert caustica.render_job(untyped, integrator="bpm", spp=1).stats["integrator"] == "bpm"
    caustica.export_scene(scene, tmp_path / "out.json")
    assert caustica.load_scene(tmp_path / "out.json").integrator_defaults["light_sampler"] == "bvh"
    out = tmp_path / "cli.exr"  # the command line takes the scene's too, and --light-sampler overrides it
    path = tmp_path / "out.json"
    assert cli.main(["render", str(path), "--spp", "2", "--seed", "3", "--quiet", "-o", str(out)]) == 0
    assert np.array_equal(caustica.read_image(str(out)), a)
    assert cli.main(["render", str(path), "--spp", "2", "--seed", "3", "--light-sampler", "power", "--quiet",
                     "-o", str(out)]) == 0
    assert np.array_equal(caustica.read_image(str(out)), c)


@pytest.mark.parametrize("block, message", [
    ({"type": "light", "light_sampler": "bvh"},
     "/integrator/light_sampler: applies to integrators path, restir, pm, ppm, sppm, pppm, bdpt, vcm, upg, but "
     "/integrator/type is 'light'"),
    ({"light_sampler": "tree"}, "/integrator/light_sampler: unknown light sampler 'tree' (allowed: power, bvh)"),
    ({"light_sampler": 1}, "/integrator/light_sampler"),
])
def test_json_scene_bad_option(block, message):
    with pytest.raises(caustica.InputError) as e:
        _scene_with(block)
    assert message in str(e.value) and "\n" not in str(e.value)


def test_converge_variant(tmp_path):
    # "path+bvh" is path with light_sampler="bvh", compared under its own name; its final image is the one
    # caustica.render gives for the passes it did.
    assert caustica._api.split_integrator_variant("path+bvh") == ("path", {"light_sampler": "bvh"})
    scene = caustica.load_scene(SCENE, width=32, height=24)
    ref = caustica.render(scene, spp=256, seed=99)
    log = caustica.converge(SCENE, integrators="path,path+bvh", time=0.4, reference=ref, metrics="relmse",
                            checkpoints=[0.2], width=32, height=24, as_frame=False)
    assert log.header["integrators"] == ["path", "path+bvh"]
    last = [r for r in log if r["integrator"] == "path+bvh"][-1]
    img = caustica.render(scene, spp=last["passes"], light_sampler="bvh")
    assert last["relmse"] == pytest.approx(caustica.metrics.relmse(img, ref), rel=1e-5)
    with pytest.raises(caustica.InputError, match="'\\+bvh' applies to path, restir, pm, ppm, sppm, pppm, bdpt, vcm, "
                                                  "upg, got 'bpm\\+bvh'"):
        caustica.converge(SCENE, integrators="bpm+bvh", time=1, reference=ref)
