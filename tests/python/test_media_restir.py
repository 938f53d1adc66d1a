"""ReSTIR DI (`restir`, integrator/restir.h) in participating media. The camera path samples free-flight
distances as the path tracer's; its first vertex where the path tracer would sample a light (a non-delta
surface or a scattering event in a medium) is the shading point, a volume point's target being the phase
function times the light's unshadowed contribution, and the final shadow ray carries the media's transmittance.
Each pass stays an unbiased estimate of the image, with or without reuse: means over independent seeds match
the path tracer's in haze with many lights, in a heterogeneous smoke blob and in an emissive medium; the
albedo-1 furnace gives Le; ReSTIR's candidates lower the noise of the direct light in haze as on surfaces.

Reuse correlates the pixels of a pass and the passes of a render, so standard errors come from independent
seeds (each a whole render), never from the spread of the pixels."""
import json
import os

import numpy as np
import pytest

import caustica
from conftest import mean_and_se, relmse
from test_media import LE, medium_sphere
from test_restir import REUSE, SCENE, quadrant_means

SEEDS = 20


def hazy_many_lights():
    """test_restir's many-lights scene (a point, a spot, an environment and 23 small area lights over a floor)
    inside a null box of haze (sigma_s 0.12, sigma_a 0.02, g 0.3) that holds the camera too."""
    d = json.load(open(SCENE))
    for light in d["lights"]:
        if "file" in light:
            light["file"] = os.path.join(os.path.dirname(SCENE), light["file"])
    d["media"] = {"haze": {"sigma_a": 0.02, "sigma_s": 0.12, "g": 0.3}}
    d["materials"]["haze"] = {"type": "null"}
    d["shapes"].append({"type": "cube", "material": "haze", "interior": "haze",
                        "transform": {"scale": [3.3, 1.6, 5.0], "translate": [0, 1.55, 0]}})
    d["camera"]["medium"] = "haze"
    return d


def seed_means(scene, integrator, spp, max_depth, seeds=SEEDS, **kw):
    m = np.array([quadrant_means(caustica.render(scene, integrator=integrator, spp=spp, seed=s, max_depth=max_depth,
                                                 **kw)) for s in range(seeds)])
    return m.mean(axis=0), m.std(axis=0, ddof=1) / np.sqrt(seeds)


def assert_means_agree(scene, max_depth, seeds=SEEDS, **kw):
    # The quadrants' and the image's means per channel within 5 standard errors of the difference (as
    # test_restir.test_matches_path_tracer: Student t with 19 degrees of freedom, one of these 15 numbers
    # fails in about 600 runs of a correct estimator).
    r, r_se = seed_means(scene, "restir", 8, max_depth, seeds, **kw)
    p, p_se = seed_means(scene, "path", 32, max_depth, seeds)
    z = (r - p) / np.sqrt(r_se ** 2 + p_se ** 2)
    assert np.all(np.abs(z) < 5), (z, r, p)
    return np.abs(z).max()


@pytest.fixture(scope="module")
def haze():
    return hazy_many_lights()


@pytest.mark.parametrize("max_depth", [2, 5], ids=["direct", "depth5"])
@pytest.mark.parametrize("reuse", ["none", "both"])
def test_matches_path_tracer_in_haze(haze, max_depth, reuse):
    # max_depth 2: direct light only, ReSTIR's alone at surface and volume shading points; 5 adds the
    # path-traced bounces after the shading point (emission reached from a volume point's phase sample not
    # added again). Measured |z| at most 1.6. With the final shadow ray's transmittance left out (vacuum),
    # these, the furnaces and the two tests below fail.
    assert_means_agree(haze, max_depth, **REUSE[reuse])


def test_less_noise_than_path_tracing_in_haze(haze):
    # As test_restir's on surfaces: RIS over 32 candidates at each shading point against the path tracer's one
    # light sample, in the haze too. Direct light, 4 passes, relMSE against a 4096-pass path-traced reference,
    # mean over 3 seeds: measured 0.37 (restir, no reuse) against 1.39 (path). Bound: half.
    ref = caustica.render(haze, integrator="path", spp=4096, seed=99, max_depth=2)
    e_path = np.mean([relmse(caustica.render(haze, spp=4, seed=s, max_depth=2), ref) for s in range(3)])
    e_ris = np.mean([relmse(caustica.render(haze, integrator="restir", spp=4, seed=s, max_depth=2,
                                            **REUSE["none"]), ref) for s in range(3)])
    assert e_ris < 0.5 * e_path, (e_ris, e_path)


@pytest.mark.parametrize("g", [0.0, 0.6])
def test_scattering_furnace(g):
    # A camera inside a null sphere of albedo-1 fog under a constant environment (test_media.py): every pixel
    # is Le. ReSTIR estimates the environment's light at the volume shading points through the boundary (the
    # transmittance on the shadow ray), the path tracer the rest. 8 seeds, 5 standard errors of their mean;
    # measured at g 0 over seeds 0-3 at 32 passes 1.0005 +- 0.0025 / 0.5005 +- 0.0013 / 2.004 +- 0.005 of
    # 1 / 0.5 / 2.
    medium = {"sigma_a": 0.0, "sigma_s": [0.8, 1.0, 1.25], "g": g}
    means = np.array([caustica.render(medium_sphere(medium, width=16), integrator="restir", spp=16, max_depth=-1,
                                      seed=s).reshape(-1, 3).mean(axis=0) for s in range(8)])
    for c in range(3):
        m, se = mean_and_se(means[:, c])
        assert 0.0 < se < 0.01 * LE[c]
        assert abs(m - LE[c]) < 5 * se, (c, m, LE[c], se)


def test_matches_path_tracer_in_smoke():
    # A point light in a heterogeneous blob (test_media_grid's smoke box): delta tracking for the camera path,
    # ratio tracking for the transmittance on the final shadow ray.
    from test_media_grid import smoke_box
    assert_means_agree(smoke_box(width=16), -1)


def test_matches_path_tracer_with_an_emissive_medium():
    # A glowing, scattering medium lit by the environment too: the medium's emission is added along the path
    # (collisions) as in the path tracer, outside ReSTIR, and not lost or doubled at a volume shading point.
    medium = {"sigma_a": 0.3, "sigma_s": 0.6, "g": 0.2, "emission": [1.5, 0.5, 0.2]}
    assert_means_agree(medium_sphere(medium, width=16), -1)


def test_threads_and_wavefront_give_the_same_image(haze):
    kw = dict(integrator="restir", spp=3, seed=5, max_depth=5)
    a = caustica.render(haze, threads=1, **kw)
    assert a.mean() > 0
    assert np.array_equal(a, caustica.render(haze, threads=2, **kw))
    assert np.array_equal(a, caustica.render(haze, wavefront=True, **kw))


CUDA, WHY = caustica.cuda_status()


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
def test_gpu_matches_cpu_in_haze(haze):
    # The same driver on CUDA (issue 7's GPU checks): quadrant means over 20 seeds within 5 standard errors of
    # the CPU's, at depth 5 with both reuses.
    g, g_se = seed_means(haze, "restir", 8, 5, device="cuda")
    c, c_se = seed_means(haze, "restir", 8, 5)
    z = (g - c) / np.sqrt(g_se ** 2 + c_se ** 2)
    assert np.all(np.abs(z) < 5), (z, g, c)
