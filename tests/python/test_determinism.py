import numpy as np
import pytest

import caustica


@pytest.mark.parametrize("sampler", ["sobol", "independent"])
@pytest.mark.parametrize("scene", ["cornell", "smallvcm-spheres"])
def test_same_seed_bit_identical_across_thread_counts(scene, sampler):
    s = caustica.load_scene(scene, width=48, height=40)
    a = caustica.render(s, spp=8, seed=7, threads=1, sampler=sampler)
    b = caustica.render(s, spp=8, seed=7, threads=2, sampler=sampler)
    c = caustica.render(s, spp=8, seed=7, threads=2, sampler=sampler)
    assert a.dtype == np.float32 and a.shape == (40, 48, 3)
    assert np.array_equal(a, b) and np.array_equal(b, c)


def test_different_seeds_differ():
    s = caustica.load_scene("cornell", width=32, height=32)
    a = caustica.render(s, spp=4, seed=1)
    b = caustica.render(s, spp=4, seed=2)
    assert not np.array_equal(a, b)


def test_time_budget_renders_whole_passes():
    s = caustica.load_scene("cornell", width=32, height=32)
    r = caustica.render_job(s, time=0.3)
    assert r.stats["passes"] >= 1
    assert r.stats["samples"] == r.stats["passes"] * 32 * 32
    assert r.stats["seconds"] >= 0.3
