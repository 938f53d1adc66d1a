"""Light tracing, bidirectional path tracing, bidirectional photon mapping and vertex connection and merging in
participating media (integrator/vcm.h, medium vertices; bpm and vcm merge at medium vertices with a ball, UPBP's
point-point estimator).

Furnaces with analytic answers (test_media.py's null sphere of medium under a constant environment: albedo 1
gives Le everywhere), cross-checks against the volumetric path tracer on scenes both render (a point light in
homogeneous fog and in a heterogeneous smoke blob, the camera inside the medium and outside it), and a
volumetric caustic (a point light focused by a glass sphere into fog) that the path tracer cannot render and
light tracing, bdpt and vcm agree on; the same caustic seen in a mirror (L S+ V S+ E), which only merging
renders (bpm, vcm, pppm). bdpt's light subpaths splat into pixels other than their camera path's, so
pixels are not quite independent: standard errors come from the image means of several seeds, or per region
from two independent halves with the box filter (a splat reaches one pixel)."""
import functools
import json
import subprocess
import sys

import numpy as np
import pytest

import caustica
from conftest import mean_and_se
from test_media import LE, medium_sphere
from test_media_emission import emission_furnace_medium
from test_media_grid import CUDA, WHY, assert_cuda_matches_cpu, grid_medium, random_grid, smoke_box
from test_media_photons import fog_box, region_means, unbounded_fog


def seed_means(scene, seeds, **opts):
    """Per-channel image means, one row per seed."""
    return np.array([caustica.render(scene, seed=s, **opts).reshape(-1, 3).mean(axis=0) for s in seeds])


# bpm merges alone (no connections): more samples and a larger ball (the automatic one is a pixel footprint) for
# the same noise.
OPTS = {"bdpt": dict(spp=8), "vcm": dict(spp=8), "bpm": dict(spp=64, volume_radius=0.3), "upg": dict(spp=8)}


@pytest.mark.parametrize("integrator", ["bdpt", "vcm", "bpm", "upg"])
@pytest.mark.parametrize("medium", [
    {"sigma_a": 0.0, "sigma_s": [0.8, 1.0, 1.25], "g": 0.5},
    {"sigma_a": 0.0, "sigma_s": [0.8, 1.0, 1.25], "g": -0.3},
    "grid",
], ids=["g0.5", "g-0.3", "grid"])
def test_scattering_furnace(medium, integrator):
    # Albedo 1, sigma_s differing per channel (each subpath's hero channel and spectral MIS), the camera inside
    # the medium: bdpt, vcm, upg (no surface to gather at: its MIS with medium vertices) and bpm (merges at
    # medium vertices alone: the ball's 4/3 pi r^3 and sigma_s each
    # count once, or the furnace is off by a third or more) see Le in every pixel - every
    # strategy's medium vertices, their connections through the null boundary (transmittance to the
    # environment) and the light subpaths from the environment, which start outside the sphere and enter it. The grid case: a random 8^3 density grid with empty cells (delta
    # tracking in both subpaths, ratio tracking on every connection). 8 seeds, 5 standard errors of their mean.
    if medium == "grid":
        values = random_grid()
        values[::3, ::2, 1::4] = 0.0
        medium = grid_medium(values, sigma_a=0.0, sigma_s=[0.8, 1.0, 1.25], g=0.3)
    means = seed_means(medium_sphere(medium, width=16), range(8), integrator=integrator, **OPTS[integrator],
                       max_depth=-1)
    for c in range(3):
        m, se = mean_and_se(means[:, c])
        assert 0.0 < se < 0.02 * LE[c]
        assert abs(m - LE[c]) < 5 * se, (c, m, LE[c], se)


def test_absorber_is_beer_lambert():
    # A pure absorber: only the environment seen through it, by the camera's escaping paths (free-flight
    # sampling in the absorber: a path that samples an event in it ends, the others carry T / P(no event)).
    # Le exp(-sigma_a R): 8 seeds, 5 standard errors of their mean.
    sa = np.array([0.2, 0.5, 1.0])
    means = seed_means(medium_sphere({"sigma_a": sa.tolist(), "sigma_s": 0.0}, width=16), range(8),
                       integrator="bdpt", spp=8, max_depth=-1)
    expected = np.array(LE) * np.exp(-sa * 2.0)
    for c in range(3):
        m, se = mean_and_se(means[:, c])
        assert abs(m - expected[c]) < 5 * se, (c, m, expected[c], se)


def outside(scene):
    """`scene` (a fog box of test_media_photons) seen from outside the fog, with the box filter."""
    scene["camera"] = {"position": [0, 0.3, 6.0], "target": [0, -0.3, 0], "up": [0, 1, 0], "fov": 45,
                       "width": 32, "height": 32}
    scene["film"] = {"filter": "box"}
    return scene


def halves(scene, integrator, spp, seeds, **opts):
    """Region means (4 x 4) of the mean of two independent renders and their standard errors from the
    renders' difference (half of it has the mean's noise; its spread over a region's pixels)."""
    a, b = (caustica.render(scene, integrator=integrator, spp=spp, seed=s, max_depth=-1, **opts).astype(np.float64)
            for s in seeds)
    H = a.shape[0] // 4
    se = (0.5 * (a - b)).reshape(4, H, 4, H, 3).std(axis=(1, 3), ddof=1) / H
    return region_means(0.5 * (a + b)), se


def z_scores(x, y):
    (a, sa), (b, sb) = x, y
    return (a - b) / np.sqrt(sa ** 2 + sb ** 2)


def with_box_filter(scene):
    scene["film"] = {"filter": "box"}
    return scene


def cross_check_scene(name):
    s = {"fog": lambda: fog_box(), "smoke": lambda: smoke_box(), "fog-outside": lambda: outside(fog_box()),
         "coloured-smoke": lambda: smoke_box()}[name]()
    if name == "coloured-smoke":
        s["media"]["fog"]["sigma_s"] = [0.3, 0.4, 0.6]
    return with_box_filter(s)


@functools.lru_cache(maxsize=None)
def path_reference(name):
    return halves(cross_check_scene(name), "path", 1024, (11, 12))


@pytest.mark.parametrize("scene", ["fog", "smoke", "fog-outside", "coloured-smoke"])
def test_cross_check_against_the_path_tracer(scene):
    # A point light in fog (homogeneous, sigma_s 0.3, g 0.3) or in a smoke blob (a 16^3 grid; the coloured one
    # scatters sigma_s 0.3 / 0.4 / 0.6 per density) over a diffuse floor, seen from inside the medium (camera
    # paths start in it) or from outside (through the box's null boundary). bdpt and the path tracer agree
    # per 8 x 8 region within 5 standard errors of their difference; so does light tracing where the camera
    # is outside the fog. (From inside, light tracing's splats of vertices near the lens grow as 1/d^2: its
    # variance is infinite and its finite-sample means run low, measured -6%; bdpt's MIS gives those
    # vertices to the camera's strategies.) A region 10% off is far outside the bound (checked below).
    s = cross_check_scene(scene)
    ref = path_reference(scene)
    bd = halves(s, "bdpt", 256, (13, 14))
    z = z_scores(bd, ref)
    assert np.abs(z).max() < 5.0, (np.abs(z).max(), bd[0][..., 1], ref[0][..., 1])
    assert np.abs(z_scores((0.9 * bd[0], bd[1]), ref)).max() > 5.0  # the check can fail
    if scene == "fog-outside":
        lt = halves(s, "light", 512, (15, 16))
        z = z_scores(lt, ref)
        assert np.abs(z).max() < 5.0, (np.abs(z).max(), lt[0][..., 1], ref[0][..., 1])


@pytest.mark.parametrize("integrator", ["vcm", "bpm"])
@pytest.mark.parametrize("scene", ["fog", "smoke", "fog-outside"])
def test_merging_cross_checks_the_path_tracer(scene, integrator):
    # vcm in the scenes above: connections at every vertex, merges on the floor and in the medium (the ball of
    # radius r_v around each camera vertex there); bpm: merges alone, with a ball of 0.15 (at its automatic
    # 0.06, a pixel footprint, its noise is heavy-tailed: one of three seed sets reached |z| 4.4). Per region
    # within 5 standard errors of the difference plus 1% of the value for the merges' kernel bias (measured
    # over three seed sets: vcm |z| <= 2.2; bpm |z| <= 3.6, at most 0.66 of the bound; with a ball of 0.3 its
    # kernel bias near the light reaches 6%, 5.5 standard errors).
    s = cross_check_scene(scene)
    ref = path_reference(scene)
    vc = halves(s, integrator, 256, (17, 18), **({"volume_radius": 0.15} if integrator == "bpm" else {}))
    d = np.abs(vc[0] - ref[0])
    assert (d < 5 * np.sqrt(vc[1] ** 2 + ref[1] ** 2) + 0.01 * ref[0]).all(), (vc[0][..., 1], ref[0][..., 1])


def test_volumetric_caustic():
    # A glass sphere below the point light focuses it into the fog (L S+ V E paths): the path tracer cannot
    # sample them (from a medium vertex its NEE is blocked by the glass and phase-sampled rays never hit a
    # point light), light tracing and bdpt can. Seen from outside the fog: bdpt and light tracing agree per
    # region within 5 standard errors, except the regions that see the sphere itself (light tracing cannot
    # connect through glass to the camera, so it renders what lies behind the sphere only where a camera path
    # reaches the light through specular surfaces alone), and in the regions below the sphere bdpt is brighter
    # than the path tracer by many standard errors: the volumetric caustic.
    s = outside(fog_box("glass"))
    bd = halves(s, "bdpt", 256, (21, 22))
    lt = halves(s, "light", 512, (23, 24))
    pt = halves(s, "path", 512, (25, 26))
    sphere = np.zeros((4, 4), bool)
    sphere[0:2, 1:3] = True  # the regions the sphere covers (rows from the top)
    z = z_scores(bd, lt)[~sphere]
    assert np.abs(z).max() < 5.0, (np.abs(z).max(), bd[0][..., 1], lt[0][..., 1])
    caustic = z_scores(bd, pt)[2:, 1:3]
    assert caustic.max() > 10.0, caustic[..., 1]
    # vcm renders every region bdpt does (what the sphere shows included): within 5 standard errors plus 1%.
    vc = halves(s, "vcm", 256, (27, 28))
    assert (np.abs(vc[0] - bd[0]) < 5 * np.sqrt(vc[1] ** 2 + bd[1] ** 2) + 0.01 * bd[0]).all()


def in_a_mirror(scene):
    """`scene` (a fog box of test_media_photons, floor removed) seen only in a mirror behind the camera, with the
    box filter: every camera path starts E S."""
    scene["camera"] = {"position": [0, 0.3, 3.0], "target": [0, -0.3, 12.0], "up": [0, 1, 0], "fov": 30,
                       "width": 32, "height": 32}
    scene["film"] = {"filter": "box"}
    scene["materials"]["mirror"] = {"type": "conductor"}
    scene["shapes"] = [sh for sh in scene["shapes"] if sh["material"] != "floor"]
    scene["shapes"].append({"type": "rectangle", "material": "mirror", "transform": {
        "scale": 3, "rotate": {"axis": [0, 1, 0], "angle": 180}, "translate": [0, 0, 6]}})
    return scene


def test_volumetric_caustic_seen_in_a_mirror():
    # The glass sphere's volumetric caustic (L S S V paths) seen only in a mirror (V S E): L S S V S E paths
    # have no connection strategy (the medium vertex's neighbours are both delta), so bdpt misses the caustic
    # (it renders the fog's glow, L V S E, and multiple scattering) and merging at medium vertices renders it,
    # as pppm's volume photons do. vcm at its automatic radii (volume 0.14, a pixel footprint where camera
    # paths scatter in the fog; surface 0.05, one at the mirror), bpm with a ball of 0.3 (its automatic one,
    # about 32 light vertices of a pass of 1024, is 1.06 here: too blurred for 5%). Region means over 4 seeds
    # each (standard errors from their spread): in the caustic's regions bdpt is far below pppm (measured
    # 16-17% in the brightest, z < -14); vcm and bpm are far above bdpt in the brightest (measured z 9.0 and
    # 6.7; bpm's next one down is too noisy to tell); everywhere vcm and bpm agree with pppm within 5 standard
    # errors of the difference plus 5% of the value for pppm's kernel bias near the fog's boundary (there pppm
    # reads 2-6% below bdpt, whose paths it does not lack; measured vcm - pppm up to +14% at z 7 in a corner,
    # bpm |z| <= 1.7), and bdpt does not.
    s = in_a_mirror(fog_box("glass"))

    def regions(integrator, seeds, **kw):
        x = np.array([region_means(caustica.render(s, integrator=integrator, seed=k, max_depth=-1, spp=256, **kw))
                      for k in seeds])
        return x.mean(axis=0), x.std(axis=0, ddof=1) / np.sqrt(len(seeds))

    pm = regions("pppm", range(4), photons=20000)
    bd = regions("bdpt", range(30, 34))
    caustic = (slice(2, 4), 2)  # the regions below the sphere where the cone is brightest
    assert z_scores(bd, pm)[caustic].max() < -10.0, z_scores(bd, pm)[..., 1]
    for integrator, seeds, kw in (("vcm", range(10, 14), {}), ("bpm", range(20, 24), {"volume_radius": 0.3})):
        x = regions(integrator, seeds, **kw)
        assert z_scores(x, bd)[2, 2].min() > 5.0, (integrator, z_scores(x, bd)[..., 1])  # bpm's row 3: noisy
        bound = 5 * np.sqrt(x[1] ** 2 + pm[1] ** 2) + 0.05 * pm[0]
        assert (np.abs(x[0] - pm[0]) < bound).all(), (integrator, x[0][..., 1], pm[0][..., 1])
        assert not (np.abs(bd[0] - pm[0]) < 5 * np.sqrt(bd[1] ** 2 + pm[1] ** 2) + 0.05 * pm[0]).all()


def test_threads_and_wavefront_give_the_same_image():
    # The wavefront driver runs the same stage functions (the transmittance of every connection and splat
    # included) with the same streams: bit for bit, as the thread count; bpm and vcm also with a volume radius
    # of their own (the medium vertices' grid split from the surface vertices' in both drivers).
    for s in (fog_box(width=16), smoke_box(width=16), unbounded_fog(width=16)):
        for integrator, extra in (("light", {}), ("bdpt", {}), ("vcm", {}), ("bpm", {}), ("upg", {}),
                                  ("vcm", {"volume_radius": 0.4}), ("bpm", {"volume_radius": 0.4})):
            kw = dict(integrator=integrator, spp=3, seed=6, max_depth=-1, **extra)
            one = caustica.render(s, threads=1, **kw)
            assert np.array_equal(one, caustica.render(s, threads=2, **kw))
            assert np.array_equal(one, caustica.render(s, wavefront=True, **kw))
    # upg's gathers need two surface vertices in a row, which these scenes (a floor in fog) never give: its
    # gathers in media (trials through the haze, the previous vertex kept across null surfaces) in smallvcm-fog.
    s = caustica.load_scene("smallvcm-fog", width=16, height=16)
    kw = dict(integrator="upg", spp=3, seed=6, max_depth=-1, radius=0.3)
    one = caustica.render(s, threads=1, **kw)
    assert np.array_equal(one, caustica.render(s, threads=2, **kw))
    assert np.array_equal(one, caustica.render(s, wavefront=True, **kw))


def test_volume_radius_of_the_merges():
    # bpm and vcm take --volume-radius in media: reported, the surface radius unchanged, a different image.
    # Without it (vcm_initial_volume_radius), vcm's is one pixel footprint where camera paths first scatter in
    # the fog: in the mirror scene (camera 3 from the mirror, the fog 7 to 11 beyond it) about 3.5 times the
    # surface radius, a footprint at the mirror; from inside the fog box, where camera paths scatter before they
    # reach the walls (median 1.5 of 2 to 4), smaller than it. bpm's, which merges alone, holds about 32 light
    # vertices of a pass (pppm's automatic volume radius): larger than the surface radius. The same on the
    # wavefront.
    s = fog_box(width=16)
    for integrator in ("vcm", "bpm"):
        auto = caustica.render_job(s, integrator=integrator, spp=2, seed=1)
        if integrator == "vcm":
            assert 0 < auto.stats["volume_radius"] < auto.stats["radius"]
        else:
            assert auto.stats["volume_radius"] > auto.stats["radius"] > 0
        given = caustica.render_job(s, integrator=integrator, spp=2, seed=1, volume_radius=0.3)
        assert given.stats["volume_radius"] == pytest.approx(0.3)
        assert given.stats["radius"] == auto.stats["radius"]
        assert not np.array_equal(auto.image, given.image)
    m = caustica.render_job(in_a_mirror(fog_box("glass")), integrator="vcm", spp=1, seed=1)
    assert 2.5 < m.stats["volume_radius"] / m.stats["radius"] < 4.5, m.stats
    for integrator in ("vcm", "bpm"):
        c = caustica.render_job(in_a_mirror(fog_box("glass")), integrator=integrator, spp=1, seed=1)
        w = caustica.render_job(in_a_mirror(fog_box("glass")), integrator=integrator, spp=1, seed=1, wavefront=True)
        assert w.stats["volume_radius"] == c.stats["volume_radius"]


def test_strategy_images_sum_to_the_image():
    # bdpt's per-strategy images (k segments, s light vertices) in fog: every contribution is recorded once.
    s = fog_box(width=16)
    # (Float sums of the same terms in another order: 1e-5 relative to the brightest pixel.) NEE from a medium
    # vertex (k2_s1_t2), light tracing from one (k2_s2_t1) and connections (k3_s2_t2) all contribute.
    r = caustica.render_job(s, integrator="bdpt", spp=2, seed=3, max_depth=4, strategy_images=True)
    total = sum(r.strategies.values())
    assert np.abs(total - r.image).max() <= 1e-5 * float(r.image.max())
    for k in ("k2_s1_t2", "k2_s2_t1", "k3_s2_t2"):
        assert r.strategies[k].mean() > 0, k
    # vcm in the mirror scene, whose only non-delta vertices lie in the fog: its merges are all volumetric and
    # recorded in the merge images (the camera vertex after the mirror is t = 3).
    r = caustica.render_job(in_a_mirror(fog_box("glass", width=16)), integrator="vcm", spp=2, seed=3, max_depth=4,
                            strategy_images=True)
    total = sum(r.strategies.values())
    assert np.abs(total - r.image).max() <= 1e-5 * float(r.image.max())
    assert r.strategies["merge_t3"].mean() > 0 and r.strategies["merge_t2"].max() == 0


@pytest.mark.parametrize("integrator", ["bdpt", "vcm", "bpm", "upg"])
@pytest.mark.parametrize("kind", ["homogeneous", "colour grid with an emission grid"])
def test_furnace_with_emission(kind, integrator):
    # test_media_emission's furnace (a scattering medium emitting the environment's radiance: L_env in every
    # pixel): the camera subpaths score the emission at their medium vertices with MIS weight 1 (no light
    # subpath starts in a medium), the scattered environment light comes by every strategy. 8 seeds, 5
    # standard errors of their mean.
    means = seed_means(medium_sphere(emission_furnace_medium(kind), width=16), range(8), integrator=integrator,
                       **OPTS[integrator], max_depth=-1)
    for c in range(3):
        m, se = mean_and_se(means[:, c])
        assert 0.0 < se < 0.02 * LE[c]
        assert abs(m - LE[c]) < 5 * se, (c, m, LE[c], se)


def test_cli_renders_fog_with_bdpt(tmp_path):
    f = tmp_path / "fog.json"
    f.write_text(json.dumps(fog_box(width=8)))
    out = tmp_path / "out.pfm"
    r = subprocess.run([sys.executable, "-m", "caustica", "render", str(f), "--integrator", "bdpt", "--spp", "2",
                        "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert out.exists()


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
def test_cuda_matches_the_cpu():
    # light, bdpt, vcm and bpm in the smoke blob on the GPU (the same stage functions) against the CPU, per
    # region.
    assert_cuda_matches_cpu(smoke_box(), (dict(integrator="bdpt", spp=16), dict(integrator="light", spp=16),
                                          dict(integrator="vcm", spp=16), dict(integrator="bpm", spp=16)))


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
def test_cuda_upg_gathers_in_fog_match_the_cpu():
    # upg in smallvcm-fog on the GPU (gathers at surfaces, trials through the haze: the same stage functions)
    # against the CPU, per region.
    scene = caustica.load_scene("smallvcm-fog", width=32, height=32)
    assert_cuda_matches_cpu(scene, (dict(integrator="upg", spp=16, radius=0.3),))


@pytest.mark.parametrize("integrator", ["bdpt", "vcm"])
def test_unbounded_fog_around_the_camera(integrator):
    # The light is in the region outside every boundary, whose medium is the camera's: its subpaths start in
    # the fog (before they started in vacuum and bdpt was 33% dark on such a scene). bdpt and vcm agree with the
    # path tracer per 8 x 8 region within 5 standard errors of the difference (vcm plus 1% for its merges'
    # kernel bias on the floor).
    s = unbounded_fog()
    ref = halves(s, "path", 1024, (31, 32))
    x = halves(s, integrator, 256, (33, 34))
    bound = 5 * np.sqrt(x[1] ** 2 + ref[1] ** 2) + (0.01 * ref[0] if integrator == "vcm" else 0.0)
    assert (np.abs(x[0] - ref[0]) < bound).all(), (x[0][..., 1], ref[0][..., 1])


@pytest.mark.parametrize("integrator,paths", [("bdpt", "light subpaths"), ("pppm", "photons")])
def test_camera_medium_not_enclosed_is_an_error(integrator, paths):
    # The camera sits inside a sphere whose interior is `m` but names `fog` as its medium: paths from the light
    # could not reach the camera's medium; one line naming the integrator (photon_render.cpp's outer_medium).
    s = medium_sphere({"sigma_a": 0.1, "sigma_s": 0.5}, width=8)
    s["media"]["fog"] = {"sigma_a": 0.1, "sigma_s": 0.2}
    s["camera"]["medium"] = "fog"
    with pytest.raises(caustica.InputError) as e:
        caustica.render(s, integrator=integrator, spp=1)
    assert str(e.value) == (f"integrator '{integrator}': the camera's medium is not the one enclosed by the shapes "
                            f"around it ({paths} could not reach it); give the medium a closed boundary shape with it "
                            "as interior, or use --integrator path")
    assert caustica.render(s, spp=1).mean() > 0  # the path tracer renders it


def test_upg_gathers_in_fog_agree_with_bdpt():
    # upg in media gathers at surface eye vertices from a previous surface vertex; its trials replay the eye's
    # free-flight sampling through the haze (upg.h), so 1/P counts the eye rays that scatter before the
    # disc. Its paths are bdpt's (a gather samples the path of a connection), so per 4 x 4 region of
    # smallvcm-fog the two agree: 8 seeds of 32 passes each, 5 standard errors of the difference, with the
    # gather radius 0.3 so that gathers carry much of the weight. Trials that ignored the haze (a measured
    # sensitivity run, with 64 passes) made upg 1-6.5% dark, 0.6-12.7 standard errors in every region; with
    # the replay the regions were within 0.7 of bdpt's.
    scene = caustica.load_scene("smallvcm-fog", width=32, height=32, filter="box")

    def regions(integrator, **kw):
        r = [caustica.render(scene, integrator=integrator, spp=32, max_depth=-1, seed=s, **kw)[..., :3]
             .reshape(4, 8, 4, 8, 3).mean(axis=(1, 3, 4)) for s in range(8)]
        return np.mean(r, axis=0), np.std(r, axis=0, ddof=1) / np.sqrt(len(r))

    u, u_se = regions("upg", radius=0.3)
    b, b_se = regions("bdpt")
    assert np.all(u_se > 0) and np.all(b_se > 0)
    z = (u - b) / np.hypot(u_se, b_se)
    assert np.abs(z).max() < 5, np.round(z, 2)
