"""Adaptive photon tracing (--photon-sampling adaptive; Hachisuka & Jensen 2011, photon/adaptive.h): on a
close-up where few photon paths reach what the camera sees, each pass's estimate has the expectation of
uniform photon tracing's (pppm: the same radii) and far less per-pixel variance at equal photons; sppm and
ppm converge to the path tracer; renders do not depend on the thread count; options are checked. The same
in participating media (pppm and sppm: volume photons and volume visible points)."""
import json
import os
import subprocess

import numpy as np
import pytest

import caustica
from conftest import mean_and_se, relmse


@pytest.fixture(scope="module")
def closeup(tmp_path_factory):
    """The Cornell box seen through a 5-degree lens aimed at the ceiling beside the light: the ceiling
    receives no direct light (the light faces down), so every pixel is photon-mapped indirect light, and
    about 0.3% of the uniform photon paths store a photon there."""
    path = tmp_path_factory.mktemp("adaptive") / "cornell.json"
    caustica.load_scene_desc("cornell").write_json(str(path))
    d = json.loads(path.read_text())
    d["camera"] = {"position": [0, 0, 0.8], "target": [0.6, 1, -0.6], "up": [0, 1, 0], "fov": 5.0,
                   "width": 16, "height": 16}
    return caustica.load_scene(d)


def renders(scene, sampling, seeds, **kw):
    opts = dict(integrator="pppm", spp=4, photons=20000, radius=0.02, sampler="independent")
    opts.update(kw)
    return np.array([caustica.render(scene, seed=s, photon_sampling=sampling, **opts)[:, :, 1] for s in seeds],
                    dtype=np.float64)


def test_adaptive_passes_have_uniform_tracings_expectation(closeup):
    # pppm's passes are independent and both samplings use the same radius per pass, so the two estimate
    # the same expectation (photon/adaptive.h: each pass is unbiased against uniform tracing). The image
    # mean and each quadrant's mean over 24 seeds agree within 5 standard errors of their difference.
    a = renders(closeup, "adaptive", range(24))
    u = renders(closeup, "uniform", range(100, 124))
    assert u.mean() > 0.01  # the ceiling is lit (indirectly)
    for sl in [(slice(None), slice(None)), (slice(0, 8), slice(0, 8)), (slice(0, 8), slice(8, 16)),
               (slice(8, 16), slice(0, 8)), (slice(8, 16), slice(8, 16))]:
        ma, sa = mean_and_se(a[:, sl[0], sl[1]].mean(axis=(1, 2)))
        mu, su = mean_and_se(u[:, sl[0], sl[1]].mean(axis=(1, 2)))
        assert abs(ma - mu) < 5 * np.hypot(sa, su), (sl, ma, mu, sa, su)


def test_adaptive_lowers_per_pixel_variance_at_equal_photons(closeup):
    # Per-pixel variance over 8 seeds at 8 passes of 20000 photon paths: measured 0.1x of uniform tracing's
    # (16 passes: 0.1x; 2 passes: 0.23x, the mutation size still adapting). 0.4 leaves room for the
    # variance estimates' own noise (8 seeds) and fails when the chains deposit only their uniform samples.
    a = renders(closeup, "adaptive", range(8), spp=8)
    u = renders(closeup, "uniform", range(8), spp=8)
    ratio = a.var(axis=0, ddof=1).mean() / u.var(axis=0, ddof=1).mean()
    assert ratio < 0.4, ratio


def test_stats_report_the_chains(closeup):
    r = caustica.render_job(closeup, integrator="sppm", spp=3, photons=20000, seed=1, photon_sampling="adaptive")
    ad = r.stats["adaptive"]
    # About 0.3% of the uniform paths are visible here (binomial: 3 x 20000 draws).
    assert 0.001 < ad["visible_fraction"] < 0.01, ad
    assert 0.0 < ad["acceptance"] < 1.0 and 1e-4 <= ad["mutation_size"] <= 1.0, ad
    assert "adaptive" not in caustica.render_job(closeup, integrator="sppm", spp=1, photons=2000).stats


ROOM = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data", "json", "sunlit-room.json")


def test_sunlit_room(tmp_path):
    # tests/data/json/sunlit-room.json: a closed room lit by the sun through a 0.2 x 0.2 hole in its
    # ceiling (about 0.17% of uniform photon paths enter and store a photon the camera sees). On the pixels
    # lit only indirectly (below the 90th percentile of uniform tracing's mean; the sunlit patch's
    # anti-aliasing noise is the same for both), per-pixel variance at equal photons over 12 seeds: measured
    # 0.035x uniform tracing's; asserted below 0.2x. pppm with one radius: the dim pixels' means agree
    # within 5 standard errors of their difference.
    s = caustica.load_scene(ROOM)
    a = renders(s, "adaptive", range(12), radius=0.05)
    u = renders(s, "uniform", range(100, 112), radius=0.05)
    dim = u.mean(axis=0) < np.percentile(u.mean(axis=0), 90)
    ratio = a.var(axis=0, ddof=1)[dim].mean() / u.var(axis=0, ddof=1)[dim].mean()
    assert ratio < 0.2, ratio
    ma, sa = mean_and_se(a[:, dim].mean(axis=1))
    mu, su = mean_and_se(u[:, dim].mean(axis=1))
    assert mu > 0.001 and abs(ma - mu) < 5 * np.hypot(sa, su), (ma, mu, sa, su)


@pytest.fixture(scope="module")
def cornell():
    return caustica.load_scene("cornell", width=48, height=48, filter="box")


@pytest.mark.parametrize("integrator", ["sppm", "ppm"])
def test_converges_to_path_tracer(cornell, integrator):
    # As test_photon.py's test for uniform photons: the diffuse Cornell box at 48 x 48, relMSE to a
    # 2048-spp path-traced reference below 0.003 after 64 passes of 20000 photons, and the error at 64
    # passes under half the error at 4. (Here about 40% of the uniform paths are visible and the chains'
    # gain is small; the test is that adaptive sampling converges to the same image.)
    ref = caustica.render(cornell, spp=2048, seed=99, sampler="independent").astype(np.float64)
    e = {p: relmse(caustica.render(cornell, integrator=integrator, spp=p, photons=20000, seed=5,
                                   photon_sampling="adaptive"), ref) for p in (4, 64)}
    assert e[64] < 0.5 * e[4] and e[64] < 0.003, e


@pytest.mark.parametrize("integrator", ["sppm", "ppm", "pppm"])
def test_deterministic_across_thread_counts(closeup, integrator):
    a = caustica.render(closeup, integrator=integrator, spp=2, photons=8000, threads=1, seed=2,
                        photon_sampling="adaptive")
    b = caustica.render(closeup, integrator=integrator, spp=2, photons=8000, threads=2, seed=2,
                        photon_sampling="adaptive")
    assert np.array_equal(a, b)
    assert a.max() > 0


@pytest.mark.parametrize("integrator", ["sppm", "ppm", "pppm"])
def test_wavefront_runs_the_same_chains(closeup, integrator):
    # The wavefront driver (wavefront_photon.h; the CUDA backend's code) runs the CPU driver's chains with the
    # same numbers: the same photons, so the image agrees to rounding (the grid adds a point's photons in
    # another order) and the chains' figures are equal; the thread count changes nothing there either.
    kw = dict(integrator=integrator, spp=3, photons=6000, seed=3, photon_sampling="adaptive")
    ref = caustica.render_job(closeup, **kw)
    r = caustica.render_job(closeup, wavefront=True, **kw)
    assert r.stats["device"].startswith("cpu (wavefront")
    assert r.stats["adaptive"] == ref.stats["adaptive"] and r.stats["adaptive"]["acceptance"] > 0
    assert ref.image.max() > 0
    np.testing.assert_allclose(r.image, ref.image, rtol=1e-5, atol=1e-9)
    one = caustica.render(closeup, wavefront=True, threads=1, **kw)
    assert np.array_equal(one, r.image)


def test_options_rejected():
    for kw, needle in [(dict(integrator="sppm", photon_sampling="mcmc"),
                        r"unknown photon sampling 'mcmc' \(allowed: uniform, adaptive\)"),
                       (dict(integrator="path", photon_sampling="adaptive"),
                        "applies to integrators ppm, sppm and pppm, got 'path'"),
                       (dict(integrator="pm", photon_sampling="adaptive"), "got 'pm'")]:
        with pytest.raises(caustica.InputError, match=needle):
            caustica.render("cornell", spp=1, **kw)


def test_cli(caustica_bin, tmp_path):
    # The run's summary names the chains' figures; a bad value, and an integrator the option does not
    # apply to (checked by the renderer), are one error line (no progress bar before it) and exit code 2.
    out = tmp_path / "a.exr"
    r = subprocess.run([caustica_bin, "render", "cornell", "--integrator", "sppm", "--photon-sampling", "adaptive",
                        "--spp", "2", "--photons", "5000", "--width", "24", "--height", "24", "--quiet",
                        "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "adaptive:" in r.stderr and "% of uniform paths visible" in r.stderr and out.exists()
    # The wavefront driver (that of --device cuda) reports the same chains.
    r2 = subprocess.run([caustica_bin, "render", "cornell", "--integrator", "sppm", "--photon-sampling", "adaptive",
                         "--spp", "2", "--photons", "5000", "--width", "24", "--height", "24", "--quiet",
                         "--wavefront", "-o", str(tmp_path / "w.exr")], capture_output=True, text=True)
    assert r2.returncode == 0, r2.stderr
    def chains(stderr):  # "adaptive: ... mutation size X" (before " -> OUT")
        line = [x for x in stderr.splitlines() if "adaptive:" in x][0]
        return line[line.index("adaptive:"):line.index(" -> ")]
    assert chains(r.stderr) == chains(r2.stderr), (r.stderr, r2.stderr)
    r = subprocess.run([caustica_bin, "render", "cornell", "--photon-sampling", "metropolis", "-o",
                        str(tmp_path / "b.exr")], capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [
        "caustica: error: unknown photon sampling 'metropolis' (allowed: uniform, adaptive)"]
    r = subprocess.run([caustica_bin, "render", "cornell", "--integrator", "pm", "--photon-sampling", "adaptive",
                        "-o", str(tmp_path / "c.exr")], capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [
        "caustica: error: --photon-sampling adaptive applies to integrators ppm, sppm and pppm, got 'pm'"]


def test_scene_file_default(tmp_path):
    # A JSON scene's "integrator": {"photon_sampling": "adaptive"} applies to sppm (stats report the chains),
    # on the wavefront driver too, not to the path tracer (no error there); it survives export; a bad value
    # names its JSON path.
    d = {"integrator": {"type": "sppm", "photons": 2000, "photon_sampling": "adaptive"},
         "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "width": 8, "height": 8},
         "shapes": [{"type": "rectangle", "emission": 1.0}, {"type": "sphere", "radius": 0.5}]}
    s = caustica.load_scene(d)
    assert s.integrator_defaults["photon_sampling"] == "adaptive"
    assert "adaptive" in caustica.render_job(s, spp=1).stats
    assert "adaptive" not in caustica.render_job(s, spp=1, photon_sampling="uniform").stats
    assert "adaptive" in caustica.render_job(s, spp=1, wavefront=True).stats
    caustica.render(s, integrator="path", spp=1)
    s.write_json(str(tmp_path / "s.json"))
    assert json.loads((tmp_path / "s.json").read_text())["integrator"]["photon_sampling"] == "adaptive"
    d["integrator"]["photon_sampling"] = "smart"
    with pytest.raises(caustica.SceneError, match=r"/integrator/photon_sampling.*unknown photon sampling 'smart'"):
        caustica.load_scene(d)


# Participating media (pppm and sppm): volume photons are visible to the volume visible points within their
# volume radius (adaptive_photons.h), and the chains' photon paths sample free-flight distances from their
# primary samples like any other numbers.

def fog_closeup(width=16):
    """test_media_photons' fog box (a point light in fog over a floor) through a 6-degree lens aimed at the
    floor's far corner: about 0.1% of uniform photon paths store a photon (mostly in the fog) near what the
    camera sees."""
    from test_media_photons import fog_box
    s = fog_box(width=width)
    s["camera"].update({"position": [0, 0, 1.9], "target": [1.6, -1.5, -1.6], "fov": 6})
    return s


def fog_renders(sampling, seeds, **kw):
    opts = dict(integrator="pppm", spp=4, photons=20000, radius=0.05, volume_radius=0.1, sampler="independent")
    opts.update(kw)
    return np.array([caustica.render(fog_closeup(), seed=s, photon_sampling=sampling, **opts)[:, :, 1]
                     for s in seeds], dtype=np.float64)


def test_media_adaptive_passes_have_uniform_tracings_expectation():
    # As on surfaces: pppm's passes with the same radii (surface and volume) estimate the same expectation
    # with both samplings. Image mean and quadrant means over 24 seeds within 5 standard errors of the
    # difference (measured: the image means 1.4 standard errors apart). Per-pixel variance at equal photons:
    # measured 0.42x uniform tracing's (0.37x over 16 other seeds); bound 0.6. Were volume photons never
    # visible, the chains would drop the fog's multiple scattering and the means would part.
    a = fog_renders("adaptive", range(24))
    u = fog_renders("uniform", range(100, 124))
    assert u.mean() > 0.01
    for sl in [(slice(None), slice(None)), (slice(0, 8), slice(0, 8)), (slice(0, 8), slice(8, 16)),
               (slice(8, 16), slice(0, 8)), (slice(8, 16), slice(8, 16))]:
        ma, sa = mean_and_se(a[:, sl[0], sl[1]].mean(axis=(1, 2)))
        mu, su = mean_and_se(u[:, sl[0], sl[1]].mean(axis=(1, 2)))
        assert abs(ma - mu) < 5 * np.hypot(sa, su), (sl, ma, mu, sa, su)
    ratio = a.var(axis=0, ddof=1).mean() / u.var(axis=0, ddof=1).mean()
    assert ratio < 0.6, ratio


@pytest.mark.parametrize("integrator", ["sppm", "ppm"])
def test_media_adaptive_converges_to_path_tracer(integrator):
    # sppm with adaptive photons in the whole fog box agrees with the path tracer per 8 x 8 region, as
    # test_media_photons' cross-check asks of uniform photons (5 standard errors over 4 seeds plus 2% for the
    # kernels' bias at the automatic radii): measured bound used to 0.47 (uniform photons: 0.39), regions
    # within -3% and +1%; 12% of the uniform paths are visible here. ppm (its measurement points and each
    # pass's volume points in one grid for the chains' visibility): measured bound used to 0.28, regions
    # within -2.4% and +1.6%.
    from test_media_photons import fog_box, region_means
    s = fog_box()
    a, b = (caustica.render(s, spp=1024, seed=k, max_depth=-1).astype(np.float64) for k in (11, 12))
    ref = region_means(0.5 * (a + b))
    se_r = (0.5 * (a - b)).reshape(4, 8, 4, 8, 3).std(axis=(1, 3), ddof=1) / 8
    runs = np.array([region_means(caustica.render(s, integrator=integrator, spp=64, photons=20000, seed=k,
                                                  max_depth=-1, photon_sampling="adaptive")) for k in range(4)])
    m, se_p = runs.mean(axis=0), runs.std(axis=0, ddof=1) / 2
    z = np.abs(m - ref) / (5 * np.sqrt(se_p ** 2 + se_r ** 2) + 0.02 * ref)
    assert z.max() < 1.0, (z.max(), m[..., 1], ref[..., 1])


@pytest.mark.parametrize("integrator", ["sppm", "pppm", "ppm"])
def test_media_threads_and_wavefront_run_the_same_chains(integrator):
    # In media too: one image for 1 and 2 threads, and the wavefront's chains are the CPU driver's (the same
    # photons and figures; the image to rounding).
    s = fog_closeup()
    kw = dict(integrator=integrator, spp=3, photons=6000, seed=3, photon_sampling="adaptive", max_depth=-1)
    ref = caustica.render_job(s, threads=1, **kw)
    assert ref.image.max() > 0 and ref.stats["adaptive"]["acceptance"] > 0
    assert np.array_equal(ref.image, caustica.render(s, threads=2, **kw))
    r = caustica.render_job(s, wavefront=True, **kw)
    assert r.stats["adaptive"] == ref.stats["adaptive"]
    np.testing.assert_allclose(r.image, ref.image, rtol=1e-5, atol=1e-9)
