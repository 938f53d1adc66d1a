"""Furnace tests: inside a closed surface of Lambert albedo a that emits Le everywhere,
every pixel converges to Le / (1 - a) (the Neumann series Le * sum a^k). The pixels are
independent estimates (each pixel's sampler is scrambled by its own hash), so their
spread gives the standard error of the image mean."""
import numpy as np
import pytest

import caustica
from conftest import mean_and_se


def sphere_furnace(albedo, Le, emitter_two_sided=True):
    return {
        "camera": {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov": 90,
                   "width": 24, "height": 24},
        "materials": {"wall": {"type": "diffuse", "reflectance": albedo, "two_sided": True}},
        "shapes": [{"type": "sphere", "center": [0.2, -0.1, 0.3], "radius": 2.0, "material": "wall",
                    "emission": Le, "emission_two_sided": emitter_two_sided}],
    }


def cube_furnace(albedo, Le):
    # A closed cube seen from inside: flip_normals makes the faces point inwards, so
    # one-sided material and emission work from the inside.
    return {
        "camera": {"position": [0.1, 0.2, 0], "target": [0.5, 0, -1], "up": [0, 1, 0], "fov": 100,
                   "width": 24, "height": 24},
        "materials": {"wall": {"type": "diffuse", "reflectance": albedo}},
        "shapes": [{"type": "cube", "material": "wall", "emission": Le, "flip_normals": True,
                    "transform": {"scale": [1.5, 1.0, 2.0], "rotate": {"axis": [1, 1, 0], "angle": 30}}}],
    }


@pytest.mark.parametrize("make", [sphere_furnace, cube_furnace], ids=["sphere", "cube"])
@pytest.mark.parametrize("albedo", [0.0, 0.5, 0.8])
@pytest.mark.parametrize("sampler", ["sobol", "independent"])
def test_furnace(make, albedo, sampler):
    Le = [1.0, 0.5, 2.0]
    img = caustica.render(make(albedo, Le), spp=64, seed=3, max_depth=-1, sampler=sampler)
    expected = np.array(Le) / (1.0 - albedo)
    for c in range(3):
        m, se = mean_and_se(img[..., c])
        if se == 0.0:  # albedo 0: every path sees exactly Le
            assert m == pytest.approx(expected[c], rel=1e-6)
            continue
        # 4 standard errors of the 576-pixel mean.
        assert abs(m - expected[c]) < 4 * se, (c, m, expected[c], se)


def test_furnace_truncated_depth():
    # max_depth D (segments) keeps D - 1 bounces: Le * sum_{k<D} a^k.
    a, Le, D = 0.6, 1.0, 3
    img = caustica.render(sphere_furnace(a, Le), spp=64, seed=1, max_depth=D)
    m, se = mean_and_se(img[..., 0])
    expected = Le * sum(a ** k for k in range(D))
    assert abs(m - expected) < 4 * se, (m, expected, se)
    # and it differs from the untruncated answer by far more than the noise
    assert abs(m - Le / (1 - a)) > 10 * se


def test_one_sided_emitter_dark_from_behind():
    # Sphere normals point outward; a one-sided emitter seen from inside emits nothing,
    # while the two-sided material still reflects the (zero) light.
    img = caustica.render(sphere_furnace(0.5, 1.0, emitter_two_sided=False), spp=4, max_depth=-1)
    assert float(np.abs(img).max()) == 0.0


@pytest.mark.parametrize("integrator", ["sppm", "ppm", "pppm"])
@pytest.mark.parametrize("photon_sampling", ["uniform", "adaptive"])
def test_photon_furnace(integrator, photon_sampling):
    # The photon integrators in the sphere furnace (albedo 0.5, Le 1: every pixel 2): emission seen
    # directly, NEE for the first bounce, photons for the rest. Photons are shared between pixels, so the
    # pixels are not independent: the standard error comes from 8 seeds' image means. 5 standard errors
    # (measured within 1.2 for every case). The density estimate has no bias here: photons are uniform on
    # the sphere, and a ball of radius r centred on a sphere's surface cuts from it a cap of area exactly
    # pi r^2 (Archimedes), the area the estimate divides by (automatic radius 0.29, sphere radius 2).
    means = [caustica.render(sphere_furnace(0.5, 1.0), integrator=integrator, spp=8, photons=20000, seed=s,
                             max_depth=-1, photon_sampling=photon_sampling)[..., 0].mean() for s in range(8)]
    m, se = mean_and_se(means)
    assert abs(m - 2.0) < 5 * se, (m, se)
