"""ReSTIR DI (integrator restir, integrator/restir.h): each pass is an unbiased estimate of the image, with or
without spatial and temporal reuse, so its mean over independent seeds matches the path tracer's; it has less
noise than the path tracer at equal passes on a many-lights scene; its reuse lowers a single pass's noise; it
does not depend on the thread count; its options fail with one clear line.

Reuse correlates the pixels of a pass and the passes of a render, so standard errors come from independent
seeds (each a whole render), never from the spread of the pixels."""
import os
import subprocess

import numpy as np
import pytest

import caustica
from conftest import mean_and_se, relmse

CUDA, WHY = caustica.cuda_status()
needs_gpu = pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")

SCENE = os.path.join(os.path.dirname(__file__), "..", "data", "json", "many-lights.json")
SEEDS = 20
REUSE = {
    "none": dict(restir_neighbors=0, restir_history=0),
    "spatial": dict(restir_history=0, restir_radius=8),
    "temporal": dict(restir_neighbors=0),
    "both": dict(restir_radius=8),
}


def quadrant_means(img):
    """The mean of each image quadrant per channel, and of the whole image: 15 numbers."""
    h, w = img.shape[0] // 2, img.shape[1] // 2
    q = [img[:h, :w], img[:h, w:], img[h:, :w], img[h:, w:], img]
    return np.concatenate([x.reshape(-1, 3).mean(axis=0) for x in q])


_path_cache = {}


def seed_means(integrator, spp, max_depth, **kw):
    key = (integrator, spp, max_depth, tuple(sorted(kw.items())))
    if integrator == "path" and key in _path_cache:
        return _path_cache[key]
    m = np.array([quadrant_means(caustica.render(SCENE, integrator=integrator, spp=spp, seed=s,
                                                 max_depth=max_depth, **kw)) for s in range(SEEDS)])
    out = m.mean(axis=0), m.std(axis=0, ddof=1) / np.sqrt(SEEDS)
    if integrator == "path":
        _path_cache[key] = out
    return out


@pytest.mark.parametrize("max_depth", [2, 5], ids=["direct", "depth5"])
@pytest.mark.parametrize("reuse", list(REUSE))
def test_matches_path_tracer(max_depth, reuse):
    # 20 seeds each; the quadrants' and the image's means per channel agree within 5 standard errors of the
    # difference (Student t with 19 degrees of freedom: a correct estimator fails one of these 15 numbers in
    # about 600 runs). max_depth 2 is direct light only (ReSTIR alone); 5 adds the path-traced bounces after
    # the shading point, whose emission hits ReSTIR already counted must not be added again.
    r, r_se = seed_means("restir", 8, max_depth, **REUSE[reuse])
    p, p_se = seed_means("path", 32, max_depth)
    z = (r - p) / np.sqrt(r_se ** 2 + p_se ** 2)
    assert np.all(np.abs(z) < 5), (z, r, p)


def test_less_noise_than_path_tracing_at_equal_passes():
    # Without reuse the passes are independent, each RIS over 32 light candidates at the shading point
    # against the path tracer's one light sample. relMSE against an 8192-pass path-traced reference
    # (direct light), 4 passes, mean over 3 seeds: measured 0.10 (restir) against 0.55 (path).
    ref = caustica.render(SCENE, integrator="path", spp=8192, seed=99, max_depth=2)
    e_path = np.mean([relmse(caustica.render(SCENE, spp=4, seed=s, max_depth=2), ref) for s in range(3)])
    e_ris = np.mean([relmse(caustica.render(SCENE, integrator="restir", spp=4, seed=s, max_depth=2,
                                            **REUSE["none"]), ref) for s in range(3)])
    assert e_ris < 0.4 * e_path, (e_ris, e_path)


def test_reuse_lowers_a_single_pass_noise():
    # The 16th pass alone (16 * image(16) - 15 * image(15): the renders are deterministic) on the floor (the
    # bottom 14 rows), against the reference, over 3 seeds: spatial and temporal reuse give each pass the
    # candidates of its neighbours and of earlier passes. The per-pixel squared relative errors are heavy-tailed
    # (a few pixels at shadow edges, where the unshadowed target picks occluded lights, reach 30-90 with or
    # without reuse and decide the mean), so the test compares their medians: measured 0.015 with both reuses
    # (0.018 spatial only, 0.015 temporal only) against 0.036 without.
    ref = caustica.render(SCENE, integrator="path", spp=8192, seed=99, max_depth=2).astype(np.float64)

    def single_pass_errors(**kw):
        out = []
        for seed in range(3):
            a = caustica.render(SCENE, integrator="restir", spp=16, seed=seed, max_depth=2, **kw)
            b = caustica.render(SCENE, integrator="restir", spp=15, seed=seed, max_depth=2, **kw)
            x = 16 * a.astype(np.float64) - 15 * b.astype(np.float64)
            out.append(((x - ref) ** 2 / (ref ** 2 + 0.01))[34:48])
        return np.median(out)

    e_none = single_pass_errors(**REUSE["none"])
    e_both = single_pass_errors(restir_radius=5)
    assert e_both < 0.6 * e_none, (e_both, e_none)


def test_furnace():
    # Inside a two-sided emitting sphere of albedo 0.5 every pixel converges to Le / (1 - a) = 2: the emitter
    # seen directly, ReSTIR's direct light from the sphere around the shading point (candidates uniform over
    # the sphere from inside), the path tracer's bounces. Standard error from 8 seeds' image means; 5 of them.
    from test_furnace import sphere_furnace
    means = [caustica.render(sphere_furnace(0.5, 1.0), integrator="restir", spp=4, seed=s, max_depth=-1,
                             restir_radius=4)[..., 0].mean() for s in range(8)]
    m, se = mean_and_se(means)
    assert abs(m - 2.0) < 5 * se, (m, se)


def test_one_driver_for_every_backend():
    # restir has one driver over the backend interface (integrator/wavefront_restir.h): --wavefront is the
    # default CPU run itself; the portable BVH (the GPU's traversal) gives the same image to within the
    # accelerators' rounding (a few hits differ: means within 1%).
    a = caustica.render(SCENE, integrator="restir", spp=3, seed=2)
    b = caustica.render(SCENE, integrator="restir", spp=3, seed=2, wavefront=True)
    assert np.array_equal(a, b)
    c = caustica.render(SCENE, integrator="restir", spp=3, seed=2, accel="bvh")
    assert abs(float(c.mean()) / float(a.mean()) - 1.0) < 0.01


@needs_gpu
@pytest.mark.parametrize("reuse", ["none", "both"])
def test_gpu_matches_cpu(reuse):
    # The same driver on CUDA: quadrant means over 20 seeds within 5 standard errors of the CPU's.
    g, g_se = seed_means("restir", 8, 5, device="cuda", **REUSE[reuse])
    c, c_se = seed_means("restir", 8, 5, **REUSE[reuse])
    z = (g - c) / np.sqrt(g_se ** 2 + c_se ** 2)
    assert np.all(np.abs(z) < 5), (z, g, c)


def test_thread_count_does_not_change_the_image():
    a = caustica.render(SCENE, integrator="restir", spp=3, seed=5, threads=1)
    b = caustica.render(SCENE, integrator="restir", spp=3, seed=5, threads=2)
    assert np.array_equal(a, b)


def test_stats_and_scene_default(tmp_path):
    r = caustica.render_job(SCENE, integrator="restir", spp=2, max_depth=2)
    st = r.stats
    assert st["integrator"] == "restir" and st["passes"] == 2
    # Camera rays, plus one shadow ray per shading point and pass.
    assert st["rays"] >= 2 * 64 * 48 and 0 < st["shadow_rays"] <= 2 * 64 * 48
    scene = {"camera": {"position": [0, 0, 3], "target": [0, 0, 0], "width": 8, "height": 8},
             "integrator": {"type": "restir", "spp": 2},
             "shapes": [{"type": "sphere", "radius": 1}], "lights": [{"type": "point", "position": [0, 2, 2]}]}
    r = caustica.render_job(scene)
    assert r.stats["integrator"] == "restir" and r.stats["passes"] == 2 and r.image.max() > 0


def _scene_with(integrator_block):
    import json
    with open(SCENE) as f:
        d = json.load(f)
    d["integrator"] = integrator_block
    return caustica.load_dict(d, base_dir=os.path.dirname(SCENE))


def test_json_scene_options(tmp_path):
    """A JSON scene's restir_* keys are the defaults of its renders: the same image as the options given in
    Python; options given in Python override them; another integrator ignores them; export keeps them."""
    keys = dict(restir_candidates=8, restir_neighbors=0, restir_radius=12, restir_history=0)
    scene = _scene_with({"type": "restir", **keys})
    assert {k: scene.integrator_defaults[k] for k in keys} == keys
    plain = _scene_with({})
    a = caustica.render(scene, spp=2, seed=3)
    b = caustica.render(plain, integrator="restir", spp=2, seed=3, **keys)
    c = caustica.render(plain, integrator="restir", spp=2, seed=3)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    d = caustica.render(scene, spp=2, seed=3, restir_candidates=32, restir_neighbors=5, restir_radius=30,
                        restir_history=20)
    assert np.array_equal(d, c)
    untyped = _scene_with(dict(keys))  # no type: path renders ignore them, restir renders take them
    assert caustica.render_job(untyped, spp=1).stats["integrator"] == "path"
    assert np.array_equal(caustica.render(untyped, integrator="restir", spp=2, seed=3), a)
    caustica.export_scene(scene, tmp_path / "out.json")
    again = caustica.load_scene(tmp_path / "out.json")
    assert {k: again.integrator_defaults[k] for k in keys} == keys


@pytest.mark.parametrize("block, message", [
    ({"type": "path", "restir_candidates": 8},
     "/integrator/restir_candidates: applies to integrator 'restir', but /integrator/type is 'path'"),
    ({"type": "restir", "restir_candidates": 0}, "/integrator/restir_candidates: expected an integer in [1, 1024]"),
    ({"restir_neighbors": 2.5}, "/integrator/restir_neighbors: expected an integer in [0, 32]"),
    ({"restir_radius": 0.5}, "/integrator/restir_radius: expected a number of pixels in [1, 10000]"),
    ({"restir_history": -1}, "/integrator/restir_history: expected a number in [0, 1000000]"),
    ({"restir_history": "long"}, "/integrator/restir_history"),
    ({"restir_bogus": 1}, "/integrator/restir_bogus"),
])
def test_json_scene_bad_options(block, message):
    with pytest.raises(caustica.InputError) as e:
        _scene_with(block)
    assert message in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("kw, message", [
    (dict(restir_candidates=0), "--restir-candidates must be an integer in [1, 1024], got 0"),
    (dict(restir_neighbors=33), "--restir-neighbors must be an integer in [0, 32], got 33"),
    (dict(restir_radius=0.5), "--restir-radius must be a number of pixels in [1, 10000], got 0.500000"),
    (dict(restir_history=-1), "--restir-history must be a number in [0, 1000000] (0: no temporal reuse), got -1.000000"),
    (dict(restir_candidates=2.5), "restir_candidates must be a non-negative integer, got 2.5"),
])
def test_bad_options(kw, message):
    with pytest.raises(caustica.InputError) as e:
        caustica.render(SCENE, integrator="restir", spp=1, **kw)
    assert str(e.value) == message


def test_options_of_another_integrator():
    with pytest.raises(caustica.InputError) as e:
        caustica.render(SCENE, integrator="path", spp=1, restir_history=0)
    assert str(e.value) == "restir_history applies to integrator 'restir', got 'path'"
    with pytest.raises(caustica.InputError) as e:
        caustica.render(SCENE, integrator="sppm", spp=1, restir_radius=4, restir_candidates=8)
    assert str(e.value) == "restir_candidates, restir_radius apply to integrator 'restir', got 'sppm'"


def test_cli(caustica_bin, tmp_path):
    out = tmp_path / "a.exr"
    r = subprocess.run([caustica_bin, "render", SCENE, "--integrator", "restir", "--spp", "2", "--restir-neighbors",
                        "3", "--restir-radius", "6", "--restir-history", "5", "--restir-candidates", "8", "--quiet",
                        "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "restir, 2 passes, 64x48" in r.stderr and out.exists()
    r = subprocess.run([caustica_bin, "render", SCENE, "--restir-history", "0", "-o", str(tmp_path / "b.exr")],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [
        "caustica: error: --restir-history applies to integrator 'restir', got 'path'"]
    r = subprocess.run([caustica_bin, "render", SCENE, "--integrator", "restir", "--restir-neighbors", "-1", "-o",
                        str(tmp_path / "c.exr")], capture_output=True, text=True)
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and "--restir-neighbors" in r.stderr, r.stderr
