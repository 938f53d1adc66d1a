"""Convergence and agreement on the built-in `cornell` (Mitsuba 3's cornell_box())."""
import numpy as np
import pytest

import caustica
from conftest import mean_and_se


def relmse_terms(x, ref):
    return ((x - ref) ** 2 / (ref ** 2 + 0.01)).ravel()


@pytest.fixture(scope="module")
def cornell_small():
    return caustica.load_scene("cornell", width=64, height=64, filter="box")


@pytest.fixture(scope="module")
def reference(cornell_small):
    return caustica.render(cornell_small, spp=1024, seed=1000, sampler="independent").astype(np.float64)


def test_relmse_falls_as_one_over_spp(cornell_small, reference):
    # Independent sampling: E[relMSE(N)] ~ V/N + V/N_ref (the reference's own noise adds).
    # 4x the samples should give (1/64 + 1/1024) / (1/16 + 1/1024) = 0.262 of the error.
    e16 = relmse_terms(caustica.render(cornell_small, spp=16, seed=1, sampler="independent"), reference)
    e64 = relmse_terms(caustica.render(cornell_small, spp=64, seed=2, sampler="independent"), reference)
    ratio = e64.mean() / e16.mean()
    # Standard error of the ratio of two independent means (delta method).
    se = ratio * np.sqrt((e64.std(ddof=1) / e64.mean()) ** 2 / e64.size + (e16.std(ddof=1) / e16.mean()) ** 2 / e16.size)
    expected = (1 / 64 + 1 / 1024) / (1 / 16 + 1 / 1024)
    assert abs(ratio - expected) < 4 * se, (ratio, expected, se)


def test_sobol_beats_independent(cornell_small, reference):
    # The Owen-scrambled Sobol sampler is unbiased like the independent one and, on this
    # smooth scene, has lower error at equal spp; a broken scramble or correlated
    # dimensions would show as a higher (or biased) error.
    ei = relmse_terms(caustica.render(cornell_small, spp=64, seed=3, sampler="independent"), reference)
    es = relmse_terms(caustica.render(cornell_small, spp=64, seed=3, sampler="sobol"), reference)
    se = np.sqrt(ei.var(ddof=1) / ei.size + es.var(ddof=1) / es.size)
    assert es.mean() < ei.mean() - 4 * se, (es.mean(), ei.mean(), se)


def test_samplers_and_accelerators_agree(cornell_small):
    # Both samplers and the accelerators (Embree, the small-scene test where the CPU has AVX2, the portable
    # BVH) estimate the same image: mean pixel values within 4 standard errors (over 4 seeds each).
    means = {}
    keys = [("sobol", "embree"), ("independent", "embree"), ("sobol", "bvh")]
    if caustica.render_job(cornell_small, spp=1).stats["accel"] == "small":
        keys.append(("sobol", "small"))
    for key in keys:
        vals = [caustica.render(cornell_small, spp=32, seed=s, sampler=key[0], accel=key[1]).mean() for s in range(4)]
        means[key] = mean_and_se(vals)
    base_m, base_se = means[("independent", "embree")]
    for key, (m, se) in means.items():
        assert abs(m - base_m) < 4 * np.hypot(se, base_se), (key, m, base_m, se, base_se)


def test_mitsuba_mean_pixel_value():
    # Mitsuba 3.9.1 llvm_ad_rgb, path, max_depth 8, box filter, 256x256, 16384 spp: the
    # mean of all pixels and channels is 0.14709 (shared/scenes/cornell-box.md). Our
    # estimate: 8 independent renders; assert within 4 standard errors of their mean.
    scene = caustica.load_scene("cornell", filter="box")
    assert (scene.width, scene.height, scene.max_depth) == (256, 256, 8)
    vals = [caustica.render(scene, spp=16, seed=100 + s, sampler="independent").mean() for s in range(8)]
    m, se = mean_and_se(vals)
    assert abs(m - 0.14709) < 4 * se, (m, se)
