"""The photon-mapping integrators: sppm, ppm, pppm."""
import numpy as np
import pytest

import caustica
from conftest import relmse


@pytest.fixture(scope="module")
def cornell():
    return caustica.load_scene("cornell", width=48, height=48, filter="box")


@pytest.fixture(scope="module")
def pt_reference(cornell):
    return caustica.render(cornell, spp=2048, seed=99, sampler="independent").astype(np.float64)


@pytest.mark.parametrize("integrator", ["sppm", "ppm", "pppm", "pm"])
def test_converges_to_path_tracer_on_diffuse_scene(cornell, pt_reference, integrator):
    # `cornell` is diffuse-only, so photon mapping and path tracing estimate the same image.
    # The error at 16x the passes must be clearly below the error at 4 passes (noise and the
    # radius bias both shrink), and at 64 passes of 20000 photons within relMSE 0.003 of the
    # path-traced reference. The reference's own noise contributes ~0.0003 (2048 spp); the
    # rest is the consistent estimator's remaining blur and noise, measured 0.0006 at the
    # automatic radius; 0.003 leaves a 5x margin and fails for a missing bounce, a wrong
    # normalisation or a grid that drops photons (each measured > 0.01).
    e = {}
    for passes in (4, 64):
        img = caustica.render(cornell, integrator=integrator, spp=passes, photons=20000, seed=5)
        assert img.dtype == np.float32 and np.isfinite(img).all()
        e[passes] = relmse(img, pt_reference)
    assert e[64] < 0.5 * e[4], e
    assert e[64] < 0.003, e
    # The mean pixel value (total energy) agrees to 1% (measured within 0.3%; a grid that
    # misses neighbour cells lost 10%).
    img = caustica.render(cornell, integrator=integrator, spp=64, photons=20000, seed=6)
    assert abs(img.mean() / pt_reference.mean() - 1) < 0.01


def test_pppm_passes_are_independent(cornell):
    # Knaus & Zwicker: each pass is independent, so passes [0, 4) and [4, 8) averaged
    # equal passes [0, 8), up to float rounding of the per-pixel averages.
    a = caustica.render(cornell, integrator="pppm", spp=4, photons=5000, seed=3, pass_offset=0)
    b = caustica.render(cornell, integrator="pppm", spp=4, photons=5000, seed=3, pass_offset=4)
    ab = caustica.render(cornell, integrator="pppm", spp=8, photons=5000, seed=3)
    assert np.allclose((a.astype(np.float64) + b) / 2, ab, rtol=1e-5, atol=1e-7)
    assert not np.allclose(a, b)


@pytest.mark.parametrize("integrator", ["sppm", "pppm", "ppm", "pm"])
def test_deterministic_across_thread_counts(integrator):
    s = caustica.load_scene("smallvcm-spheres", width=40, height=32)
    a = caustica.render(s, integrator=integrator, spp=3, photons=8000, threads=1, seed=2)
    b = caustica.render(s, integrator=integrator, spp=3, photons=8000, threads=2, seed=2)
    assert np.array_equal(a, b)


def test_point_in_glass_path_tracing_fails_sppm_does_not():
    s = caustica.load_scene("point-in-glass", width=32, height=32)
    pt = caustica.render(s, spp=16)
    assert float(pt.max()) == 0.0  # no light path from a point light through glass is sampled
    ref = caustica.render(s, integrator="sppm", spp=256, photons=20000, seed=100).astype(np.float64)
    assert ref.mean() > 0.01
    e4 = relmse(caustica.render(s, integrator="sppm", spp=4, photons=20000, seed=1), ref)
    e32 = relmse(caustica.render(s, integrator="sppm", spp=32, photons=20000, seed=1), ref)
    assert e32 < 0.5 * e4, (e4, e32)


def test_photon_options_rejected():
    for kw, needle in [(dict(photons=0), "photons must be a positive integer"),
                       (dict(radius=-1.0), "radius must be a positive number"),
                       (dict(alpha=1.5), r"alpha must be in \(0, 1\)"),
                       (dict(pass_offset=-1), "pass_offset must be a non-negative integer"),
                       (dict(k=0), "k must be a positive integer")]:
        with pytest.raises(caustica.InputError, match=needle):
            caustica.render("cornell", integrator="sppm", **kw)


def test_sppm_beats_path_tracing_on_the_glass_box():
    # The default scene: caustics from the glass sphere on the glossy floor. A long path-traced
    # render (area light: PT converges, slowly) is the reference. SPPM must agree with it in
    # total energy (mean within 2%: measured 0.1% at 64x64; the reference's own noise on the
    # mean is ~0.3%) and reach less than half its error at equal cost. Equal cost is fixed in
    # passes, not wall time, so that the test is deterministic: 1600 spp of `path` and 124 SPPM
    # passes of 20000 photons each took 2.1-2.3 s on a 2-core AMD EPYC (2026-12-01). With 2 s
    # wall-time budgets the ratio was 0.25-0.52 over runs (it failed once in CI at 0.52): since
    # the Sobol sampler, PT's error here fell, and the reference's own noise (8192 spp, about a
    # fifth of PT's error at 1600 spp) is added to both errors, which narrows the gap. Hence a
    # 16384-spp reference: measured ratio 0.38 with a 32768-spp one, 0.50 with the 8192-spp one.
    s = caustica.load_scene("smallvcm-spheres", width=32, height=32)
    ref = caustica.render(s, spp=16384, seed=77).astype(np.float64)
    pt = caustica.render(s, spp=1600, seed=1)
    sp = caustica.render(s, integrator="sppm", spp=124, seed=1, photons=20000)
    assert abs(sp.mean() / ref.mean() - 1) < 0.02
    assert relmse(sp, ref) < 0.5 * relmse(pt, ref), (relmse(sp, ref), relmse(pt, ref))
    # PPM's fixed measurement points must carry the specular branches' Fresnel weights
    # (a single random branch per pixel gave 40x the error).
    # Compared at equal passes with SPPM (deterministic, unlike equal time on a shared machine;
    # the figures below were measured against the earlier 8192-spp reference):
    # within 3x of SPPM's error. Measured 1.9-2.4x over seeds 1-4 since the sampler's scramble
    # hash takes its seed as a multiplier too (2026-12-01): that lowered SPPM's error at 32 passes
    # (relMSE 0.0049-0.0137 before, 0.0044-0.0047 after) and left PPM's (0.008-0.024, set by where
    # its one measurement point per pixel lies); before, 1.2x was measured and 2x was the bound.
    pp = caustica.render(s, integrator="ppm", spp=32, seed=1, photons=20000)
    sp32 = caustica.render(s, integrator="sppm", spp=32, seed=1, photons=20000)
    assert abs(pp.mean() / ref.mean() - 1) < 0.02
    assert relmse(pp, ref) < 3 * relmse(sp32, ref), (relmse(pp, ref), relmse(sp32, ref))
    # Jensen's photon mapping (fixed maps, caustic map + final gathering) agrees in energy
    # too (biased by its fixed k-nearest radius, measured within 1% here).
    pm = caustica.render(s, integrator="pm", spp=64, photons=100000, seed=1)
    assert abs(pm.mean() / ref.mean() - 1) < 0.03


def test_sobol_camera_samples_beat_independent_ones_in_sppm():
    # SPPM's camera pass draws its visible points from the pixel sampler. With a Laine-Karras hash whose
    # seed was only added (Burley 2020's listing), a shift of those draws by one dimension pair (a pinhole
    # camera no longer taking a lens sample) made Sobol's error at equal passes 1.07x the independent
    # sampler's instead of below it (relMSE 0.0045 against 0.0042, seeds 1-4); with the seed also a
    # multiplier (Vegdahl 2021, as pbrt-v4) it is 0.63x (0.0027 against 0.0042). Bound: 0.85, the
    # measured ratio plus about two standard errors of it (per-seed spreads 0.0003 and 0.0012).
    s = caustica.load_scene("smallvcm-spheres", width=32, height=32)
    ref = caustica.render(s, spp=8192, seed=77).astype(np.float64)
    err = {smp: np.mean([relmse(caustica.render(s, integrator="sppm", spp=133, seed=seed, photons=20000,
                                                sampler=smp), ref) for seed in (1, 2, 3, 4)])
           for smp in ("sobol", "independent")}
    assert err["sobol"] < 0.85 * err["independent"], err


def test_cli_photon_integrator_and_checkpoint(caustica_bin, tmp_path):
    import subprocess
    import time
    out = tmp_path / "c.exr"
    p = subprocess.Popen([caustica_bin, "render", "cornell", "--integrator", "sppm", "--time", "8",
                          "--checkpoint", "0.5", "--width", "64", "--height", "64", "--photons", "20000",
                          "--quiet", "-o", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # Poll (a loaded machine delays the first pass): the checkpoint must be on disk while
    # the 8-second render is still running.
    deadline = time.monotonic() + 6.0
    while not out.exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert out.exists() and p.poll() is None
    early = caustica.read_image(out)
    assert early.shape == (64, 64, 3) and early.mean() > 0.05
    _, err = p.communicate(timeout=120)
    assert p.returncode == 0, err
    assert "photons/s" in err and "initial radius" in err
    assert sorted(q.name for q in tmp_path.iterdir()) == ["c.exr"]
    r = subprocess.run([caustica_bin, "render", "cornell", "--integrator", "sppm", "--alpha", "2", "-o",
                        str(tmp_path / "d.exr")], capture_output=True, text=True)
    assert r.returncode == 2 and "--alpha expects a number in (0, 1)" in r.stderr


def test_stochastic_hashing_converges(cornell, pt_reference):
    # One photon per grid cell, its power scaled by the cell's count: unbiased per cell, so
    # the energy is kept (mean within 1%) and the error still falls with passes, though
    # with more noise than the full grid.
    e = {}
    for passes in (4, 64):
        img = caustica.render(cornell, integrator="pppm", spp=passes, photons=20000, seed=5, stochastic_hash=True)
        e[passes] = relmse(img, pt_reference)
    assert e[64] < 0.5 * e[4], e
    assert abs(img.mean() / pt_reference.mean() - 1) < 0.01
