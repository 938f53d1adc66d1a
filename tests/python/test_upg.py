"""Unbiased photon gathering (`upg`, integrator/upg.h): Qin et al. 2015's gathering technique with the
trial estimate of 1/P, combined with BDPT's strategies.

Every tolerance is a number of standard errors measured from independent seeds. Small images (16x16:
the automatic radius, one pixel footprint, is then large (0.17 on cornell) and the gathers carry much of
the MIS weight of the paths they can sample)."""
import numpy as np
import pytest

import caustica
from test_bidirectional import regions, seeded_regions, sds_scene


@pytest.mark.parametrize("name", ["cornell", "smallvcm-spheres"])
def test_upg_matches_path_tracing_per_region(name):
    # cornell (diffuse) and the SmallVCM box with the ceiling area light (glossy floor, mirror and glass
    # spheres): 16 region means within 4 combined standard errors of the path tracer's (16 seeds each).
    s = caustica.load_scene(name, width=16, height=16)
    m, se = seeded_regions(s, "upg", 4, range(300, 316))
    mr, ser = seeded_regions(s, "path", 128, range(200, 216))
    z = np.abs(m - mr) / np.sqrt(se ** 2 + ser ** 2)
    assert z.max() < 4.0, (np.round(z, 1), np.round(m / mr, 3))


def test_upg_unbiased_at_one_pass_and_with_a_small_radius():
    # Unbiased at any sample count: one pass per seed; and for any radius (0.2 of the automatic one, where
    # the connections keep most of the weight, and twice it, where the gathers take most).
    s = caustica.load_scene("cornell", width=16, height=16)
    mr, ser = seeded_regions(s, "path", 128, range(200, 216))
    for kw in ({}, {"radius": 0.034}, {"radius": 0.34}):
        m, se = seeded_regions(s, "upg", 1, range(400, 432), **kw)
        z = np.abs(m - mr) / np.sqrt(se ** 2 + ser ** 2)
        assert z.max() < 4.0, (kw, np.round(z, 1))


def test_gathers_contribute():
    # The gathers are not a no-op: with the same seed upg's image differs from bdpt's. On diffuse cornell
    # they do not lower the noise (per-pixel standard deviation over 8 seeds: measured ratio 1.00, the
    # noise comes from the camera paths' own sampling); the bound only guards against a blow-up.
    s = caustica.load_scene("cornell", width=16, height=16)
    u = np.array([caustica.render(s, integrator="upg", spp=2, seed=k, sampler="independent") for k in range(8)])
    b = np.array([caustica.render(s, integrator="bdpt", spp=2, seed=k, sampler="independent") for k in range(8)])
    assert not np.array_equal(u[0], b[0])
    assert u.std(0).mean() < 1.2 * b.std(0).mean(), (u.std(0).mean(), b.std(0).mean())


def test_pure_sds_from_a_point_light_stays_black():
    # L S S D S E only (test_bidirectional's scene): a gathered path is a connection of the photon y_s to
    # the previous eye vertex z_{t-1}, which here is the mirror (delta): no gathered path has a non-zero
    # contribution, so upg, being unbiased, is exactly black like bdpt and path (only merging, biased,
    # renders it). See docs/integrators.md, "upg".
    s = caustica.load_scene(sds_scene())
    assert float(caustica.render(s, integrator="upg", spp=4).max()) == 0.0


def test_deterministic_across_thread_counts():
    s = caustica.load_scene("smallvcm-spheres", width=24, height=16)
    a = caustica.render(s, integrator="upg", spp=2, threads=1, seed=2)
    b = caustica.render(s, integrator="upg", spp=2, threads=2, seed=2)
    assert np.array_equal(a, b)
    c = caustica.render(s, integrator="upg", spp=2, threads=2, seed=3)
    assert not np.array_equal(a, c)
