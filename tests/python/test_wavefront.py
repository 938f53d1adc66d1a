"""The wavefront drivers (integrator/wavefront_path.h, wavefront_photon.h, wavefront_vcm.h) from Python and
the command line: on the CPU (`--wavefront`) they are the CUDA backend's driver code, and must give the path
tracer's and the bidirectional integrators' images bit for bit (the photon integrators' to rounding);
on a GPU (`--device cuda`) the image must agree with the CPU's within standard errors. GPU tests are
skipped, saying why, where there is no usable CUDA device."""
import os
import subprocess
import sys

import numpy as np
import pytest

import caustica
from test_bidirectional import seeded_regions

CUDA, WHY = caustica.cuda_status()
needs_gpu = pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")


def cli(*args):
    return subprocess.run([sys.executable, "-m", "caustica.cli", *args], capture_output=True, text=True)


@pytest.mark.parametrize("switches", [{}, {"compaction": False}, {"sort_materials": True},
                                      {"accel": "bvh", "sort_materials": True}])
def test_cpu_wavefront_gives_the_path_tracers_image(switches):
    s = caustica.load_scene("smallvcm-spheres", width=24, height=20)
    accel = switches.get("accel", "auto")
    ref = caustica.render_job(s, spp=2, seed=3, accel=accel)
    r = caustica.render_job(s, spp=2, seed=3, wavefront=True, **switches)
    assert r.stats["accel"] == ref.stats["accel"]
    assert r.stats["device"] == f"cpu (wavefront, {'portable BVH' if accel == 'bvh' else r.stats['accel']})"
    ref = ref.image
    assert r.stats["rays"] > 0 and r.stats["shadow_rays"] > 0
    assert np.array_equal(r.image, ref)


def test_first_bounce_cache_needs_fixed_camera_rays(tmp_path):
    s = caustica.load_scene("cornell", width=16, height=16)
    ref = caustica.render(s, spp=3, jitter=False)
    img = caustica.render(s, spp=3, jitter=False, wavefront=True, cache_first_bounce=True)
    assert np.array_equal(img, ref)
    out = tmp_path / "x.exr"
    for args, msg in ((["--wavefront", "--cache-first-bounce"], "--cache-first-bounce needs --no-jitter"),
                      (["--sort-materials"], "--sort-materials applies to the wavefront path tracer"),
                      (["--no-compaction"], "--no-compaction applies to the wavefront path tracer"),
                      (["--wavefront", "--integrator", "pm", "--k", "300"],
                       "--k: at most 256 photons per estimate on the wavefront, got 300"),
                      (["--wavefront", "--integrator", "bdpt", "--strategy-images", str(tmp_path)],
                       "--strategy-images runs on the CPU driver only"),
                      (["--wavefront", "--integrator", "sppm", "--sort-materials"],
                       "--sort-materials applies to the wavefront path tracer"),
                      (["--no-jitter", "--integrator", "bdpt"], "--no-jitter applies to integrator 'path'")):
        r = cli("render", "cornell", "--spp", "1", "--width", "8", "--height", "8", "--quiet", "-o", str(out), *args)
        assert r.returncode == 2 and msg in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1
        assert not out.exists()


@pytest.mark.parametrize("integrator", ["sppm", "ppm", "pppm", "pm"])
def test_cpu_wavefront_photon_mapping_matches_the_photon_integrator(integrator):
    # The same stage functions; a visible point may add its photons in another order (in doubles), so
    # values agree to 1e-5 relative (one photon moves a pixel by 1e-3 of its value or more here). pm traces
    # its photons once.
    s = caustica.load_scene("smallvcm-spheres", width=24, height=20)
    ref = caustica.render_job(s, integrator=integrator, spp=3, seed=4)
    r = caustica.render_job(s, integrator=integrator, spp=3, seed=4, wavefront=True)
    assert r.stats["device"] == f"cpu (wavefront, {r.stats['accel']})"
    assert r.stats["photons"] == ref.stats["photons"] == (1 if integrator == "pm" else 3) * 24 * 20
    ref = ref.image
    assert r.stats["radius"] > 0
    np.testing.assert_allclose(r.image, ref, rtol=1e-5, atol=1e-9)


@pytest.mark.parametrize("integrator", ["light", "bdpt", "bpm", "vcm", "upg"])
def test_cpu_wavefront_bidirectional_gives_the_cpu_drivers_image(integrator):
    # The same stage functions in the same order per path and per pixel: bit for bit (wavefront_vcm.h).
    s = caustica.load_scene("smallvcm-spheres", width=24, height=20)
    ref = caustica.render_job(s, integrator=integrator, spp=2, seed=8)
    r = caustica.render_job(s, integrator=integrator, spp=2, seed=8, wavefront=True)
    assert r.stats["device"] == f"cpu (wavefront, {r.stats['accel']})"
    for key in ("photons", "rays", "radius"):
        assert r.stats[key] == ref.stats[key], key
    stages = r.stats["stage_seconds"]
    assert set(stages) == {"light_subpaths", "grid", "camera_subpaths", "accumulate"}
    assert all(v >= 0 for v in stages.values()) and sum(stages.values()) <= r.stats["seconds"]
    assert (r.stats["stored_photons"] > 0) == (integrator != "light")  # light tracing keeps no vertices
    assert r.image.sum() > 0
    assert np.array_equal(r.image, ref.image)


def _refuses_huge_allocations():
    """Whether a 0.86 TB allocation fails at once here (heuristic or strict overcommit, under 512 GiB)."""
    try:
        with open("/proc/sys/vm/overcommit_memory") as f:
            mode = int(f.read())
    except (OSError, ValueError):
        return False
    return mode in (0, 2) and os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") < 512 * 2 ** 30


@pytest.mark.skipif(not _refuses_huge_allocations(), reason="this machine could grant a 0.86 TB allocation")
def test_too_many_light_subpaths_for_memory_is_a_one_line_error(tmp_path):
    out = tmp_path / "x.exr"
    r = cli("render", "cornell", "--integrator", "bdpt", "--wavefront", "--photons", "2000000000", "--spp", "1",
            "--width", "8", "--height", "8", "--quiet", "-o", str(out))
    assert r.returncode == 2, r.stderr
    assert "not enough memory for this render" in r.stderr and "--photons 2000000000" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not out.exists()


@needs_gpu
@pytest.mark.parametrize("integrator", ["sppm", "ppm", "pppm", "pm", "light", "bdpt", "bpm", "vcm", "upg"])
def test_gpu_photon_and_bidirectional_integrators_match_the_cpu_per_region(integrator):
    s = caustica.load_scene("smallvcm-spheres", width=32, height=32)
    m_cpu, se_cpu = seeded_regions(s, integrator, 8, range(100, 112))
    m_gpu, se_gpu = seeded_regions(s, integrator, 8, range(200, 212), device="cuda")
    z = np.abs(m_cpu - m_gpu) / np.sqrt(se_cpu ** 2 + se_gpu ** 2)
    assert z.max() < 4.0, np.round(z, 1)


@needs_gpu
@pytest.mark.parametrize("name", ["cornell", "smallvcm-spheres"])
def test_gpu_path_tracer_matches_the_cpu_per_region(name):
    # 16 region means of 12 seeds each on the CPU and on the GPU: within 4 combined standard errors.
    s = caustica.load_scene(name, width=32, height=32)
    m_cpu, se_cpu = seeded_regions(s, "path", 16, range(100, 112))
    m_gpu, se_gpu = seeded_regions(s, "path", 16, range(200, 212), device="cuda")
    z = np.abs(m_cpu - m_gpu) / np.sqrt(se_cpu ** 2 + se_gpu ** 2)
    assert z.max() < 4.0, np.round(z, 1)


@needs_gpu
def test_gpu_render_from_the_command_line(tmp_path):
    out = tmp_path / "gpu.exr"
    r = cli("render", "cornell", "--device", "cuda", "--spp", "4", "--width", "64", "--height", "48", "--quiet",
            "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert "on cuda:0" in r.stderr
    img = caustica.read_image(out)
    assert img.shape == (48, 64, 3) and np.isfinite(img).all() and img.mean() > 0.05


@pytest.mark.parametrize("integrator", ["path", "sppm", "ppm"])
def test_cpu_wavefront_is_deterministic_across_thread_counts(integrator):
    s = caustica.load_scene("smallvcm-spheres", width=20, height=16)
    kw = dict(integrator=integrator, spp=2, seed=8, wavefront=True, stochastic_hash=integrator == "sppm")
    assert np.array_equal(caustica.render(s, threads=1, **kw), caustica.render(s, threads=2, **kw))


def textured_sun_scene(tmp_path):
    """test_envmap's floor and box under an environment map with a sun (a texture file), the box's
    reflectance an image texture: what the device copy of a scene must carry beyond flat arrays."""
    from test_envmap import sun_scene
    d = sun_scene(tmp_path)
    checker = np.indices((8, 8)).sum(0) % 2
    tex = np.stack([0.2 + 0.6 * checker, 0.5 - 0.3 * checker, 0.3 + 0.0 * checker], -1).astype(np.float32)
    caustica.write_image(tmp_path / "checker.exr", tex)
    d["materials"]["box"] = {"type": "diffuse", "reflectance": {"texture": "checker.exr"}}
    return caustica.load_dict(d, base_dir=str(tmp_path))


def test_cpu_wavefront_with_textures_and_an_environment_map(tmp_path):
    s = textured_sun_scene(tmp_path)
    for integrator in ("path", "sppm"):
        ref = caustica.render(s, integrator=integrator, spp=2, seed=5, max_depth=4)
        img = caustica.render(s, integrator=integrator, spp=2, seed=5, max_depth=4, wavefront=True)
        np.testing.assert_allclose(img, ref, rtol=1e-5, atol=1e-9)


@needs_gpu
@pytest.mark.parametrize("integrator", ["path", "sppm"])
def test_gpu_with_textures_and_an_environment_map(tmp_path, integrator):
    s = textured_sun_scene(tmp_path)
    m_cpu, se_cpu = seeded_regions(s, integrator, 8, range(100, 112), max_depth=4)
    m_gpu, se_gpu = seeded_regions(s, integrator, 8, range(200, 212), max_depth=4, device="cuda")
    z = np.abs(m_cpu - m_gpu) / np.sqrt(se_cpu ** 2 + se_gpu ** 2 + 1e-30)
    assert z.max() < 4.0, np.round(z, 1)


@needs_gpu
@pytest.mark.parametrize("integrator", ["sppm", "ppm", "pppm"])
def test_gpu_adaptive_photon_tracing_matches_the_cpu_per_region(integrator):
    # --photon-sampling adaptive: 2 chains of 2048 steps per pass, each one GPU thread.
    s = caustica.load_scene("smallvcm-spheres", width=32, height=32)
    kw = dict(photons=4096, photon_sampling="adaptive")
    m_cpu, se_cpu = seeded_regions(s, integrator, 8, range(100, 112), wavefront=True, **kw)
    m_gpu, se_gpu = seeded_regions(s, integrator, 8, range(200, 212), device="cuda", **kw)
    z = np.abs(m_cpu - m_gpu) / np.sqrt(se_cpu ** 2 + se_gpu ** 2)
    assert z.max() < 4.0, np.round(z, 1)


@needs_gpu
@pytest.mark.parametrize("kw", [{"integrator": "path", "sort_materials": True},
                                {"integrator": "sppm", "stochastic_hash": True}, {"integrator": "pppm"},
                                {"integrator": "sppm", "photon_sampling": "adaptive", "photons": 4096}])
def test_gpu_images_depend_only_on_the_seed(kw):
    # No atomics in any sum and deterministic CUB sorts: two GPU renders with one seed are the same bits.
    s = caustica.load_scene("smallvcm-spheres", width=48, height=32)
    a = caustica.render(s, spp=3, seed=2, device="cuda", **kw)
    b = caustica.render(s, spp=3, seed=2, device="cuda", **kw)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, caustica.render(s, spp=3, seed=3, device="cuda", **kw))
