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


def _has_avx2():
    try:
        with open("/proc/cpuinfo") as f:
            return " avx2" in f.read()
    except OSError:
        return False


@pytest.mark.parametrize("scene,threads,sampler", [("cornell", 1, "sobol"), ("cornell", 2, "sobol"),
                                                   ("smallvcm-spheres", 2, "sobol"), ("cornell", 2, "independent"),
                                                   ("smallvcm-spheres", 1, "independent")])
def test_lanes_give_the_same_image_bit_for_bit(scene, threads, sampler):
    # path's lane-parallel driver (eight paths in lockstep, integrator/path_lanes.h) against one path at a
    # time: the same bits in every pixel, and the same ray counts. 44 is not a multiple of the 8 lanes.
    # smallvcm-spheres: its mirror, glass and glossy vertices run the scalar stages in their lanes.
    s = caustica.load_scene(scene, width=44, height=36)
    a = caustica.render_job(s, spp=6, seed=5, threads=threads, lanes=True, sampler=sampler)
    b = caustica.render_job(s, spp=6, seed=5, threads=threads, lanes=False, sampler=sampler)
    assert b.stats["lanes"] == 0
    if not _has_avx2():
        assert a.stats["lanes"] == 0
        pytest.skip("this CPU has no AVX2: the lanes do not run here")
    assert a.stats["lanes"] == 8
    assert np.array_equal(a.image, b.image)
    assert (a.stats["rays"], a.stats["shadow_rays"]) == (b.stats["rays"], b.stats["shadow_rays"])


@pytest.mark.parametrize("scene,options", [("smallvcm-sun", {}), ("smallvcm-env", {}),
                                           ("cornell", {"wavefront": True}), ("cornell", {"integrator": "sppm"})])
def test_lanes_only_where_they_cover_the_render(scene, options):
    s = caustica.load_scene(scene, width=16, height=16)
    r = caustica.render_job(s, spp=1, seed=1, **options)
    assert r.stats["lanes"] == 0
