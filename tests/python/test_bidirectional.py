"""The bidirectional integrators: light (light tracing), bdpt, bpm, vcm (integrator/vcm.h).

Statistical checks with fixed seeds; every tolerance is a number of standard errors measured from
independent seeds (stated beside each assertion), or an error bound with its measured value."""
import os

import numpy as np
import pytest

import caustica
from conftest import relmse

BIDIR = ["light", "bdpt", "bpm", "vcm"]


def regions(img, n=4):
    """Mean of each of n x n blocks (all channels)."""
    h, w = img.shape[0] // n, img.shape[1] // n
    return np.array([[img[i * h:(i + 1) * h, j * w:(j + 1) * w].mean() for j in range(n)] for i in range(n)])


def seeded_regions(scene, integrator, spp, seeds, **kw):
    """Region means over several seeds: (mean, standard error of the mean)."""
    r = np.array([regions(caustica.render(scene, integrator=integrator, spp=spp, seed=s, sampler="independent",
                                          **kw).astype(np.float64)) for s in seeds])
    return r.mean(0), r.std(0, ddof=1) / np.sqrt(len(seeds))


def plane_scene(a, I, h):
    """A diffuse plane z = 0 (albedo a, 20 x 20) under a point light of intensity I at height h, seen from
    z = 2 straight down."""
    return {
        "film": {"width": 24, "height": 24, "filter": "box"},
        "camera": {"position": [0, 0, 2.0], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40},
        "materials": {"white": {"type": "diffuse", "reflectance": [a, a, a]}},
        "shapes": [{"type": "rectangle", "material": "white", "transform": {"scale": 10}}],
        "lights": [{"type": "point", "position": [0, 0, h], "intensity": I}],
    }


@pytest.fixture(scope="module")
def cornell():
    return caustica.load_scene("cornell", width=32, height=32)  # Mitsuba's gaussian filter: splats cover 4x4 pixels


@pytest.fixture(scope="module")
def smallvcm():
    return caustica.load_scene("smallvcm-spheres", width=32, height=32)


@pytest.fixture(scope="module")
def cornell_ref(cornell):
    return caustica.render(cornell, spp=2048, seed=99, sampler="independent").astype(np.float64)


@pytest.fixture(scope="module")
def cornell_path_regions(cornell):
    return seeded_regions(cornell, "path", 128, range(200, 216))


@pytest.fixture(scope="module")
def smallvcm_path_regions(smallvcm):
    return seeded_regions(smallvcm, "path", 128, range(200, 216))


@pytest.mark.parametrize("integrator", ["light", "bdpt"])
def test_unbiased_ones_match_path_tracing_per_region(cornell, cornell_path_regions, integrator):
    # cornell is diffuse only, so light tracing sees everything. 16 regions, each mean within 4 combined
    # standard errors (16 seeds each side, so the t-distribution's tail beyond 4 is 0.1% per region); a wrong camera importance (cos^3 -> cos^2) or filter weight
    # shifts regions by 3-10%, i.e. 5-20 SE.
    m, se = seeded_regions(cornell, integrator, 16, range(300, 316))
    mr, ser = cornell_path_regions
    z = np.abs(m - mr) / np.sqrt(se ** 2 + ser ** 2)
    assert z.max() < 4.0, np.round(z, 1)


@pytest.mark.parametrize("integrator,photons", [("light", 256), ("light", 4096), ("bdpt", 256), ("bdpt", 4096)])
def test_light_subpaths_per_pass_keep_them_unbiased(cornell, cornell_path_regions, integrator, photons):
    # --photons N light subpaths per pass (32 x 32 = 1024 pixels: a quarter and four times the default):
    # camera path i connects to subpath i mod N, light tracing splats all N with weight 1/N. Same criterion as
    # above: every region mean within 4 combined standard errors of the path tracer's.
    m, se = seeded_regions(cornell, integrator, 16, range(400, 416), photons=photons)
    mr, ser = cornell_path_regions
    z = np.abs(m - mr) / np.sqrt(se ** 2 + ser ** 2)
    assert z.max() < 4.0, np.round(z, 1)
    st = caustica.render_job(cornell, integrator=integrator, spp=3, photons=photons).stats
    assert st["photons"] == 3 * photons


def test_bdpt_matches_path_tracing_with_mirror_and_glass(smallvcm, smallvcm_path_regions):
    # The SmallVCM box with the ceiling area light, glossy floor, mirror and glass spheres: bdpt sees every
    # path the path tracer sees; 16 region means within 4 combined standard errors.
    m, se = seeded_regions(smallvcm, "bdpt", 16, range(300, 316))
    mr, ser = smallvcm_path_regions
    z = np.abs(m - mr) / np.sqrt(se ** 2 + ser ** 2)
    assert z.max() < 4.0, np.round(z, 1)


def test_light_tracing_on_smallvcm_away_from_the_spheres(smallvcm, smallvcm_path_regions):
    # Light tracing cannot sample diffuse surfaces seen in the mirror or through the glass (L D S E);
    # the upper half of the image (ceiling, walls, light) has no specular surface: 4 SE there.
    m, se = seeded_regions(smallvcm, "light", 16, range(300, 316))
    mr, ser = smallvcm_path_regions
    z = np.abs(m - mr) / np.sqrt(se ** 2 + ser ** 2)
    assert z[:2].max() < 4.0, np.round(z, 1)
    # ... and the spheres' regions do miss energy (measured 0.6-0.8 of the reference).
    assert (m[2:, 1:3] / mr[2:, 1:3]).min() < 0.85


@pytest.mark.parametrize("integrator", BIDIR)
def test_converges_to_path_tracer_on_cornell(cornell, cornell_ref, integrator):
    # relMSE against a 2048-spp path-traced reference (its own noise ~0.0004) falls with passes and ends
    # low. The bound 0.012 is 1.4-5x the measured error at 64 passes (bpm's is the largest: merging at
    # every vertex with the automatic radius, r_1 = 2 pixel footprints, blurs; 0.0087 measured).
    e = {}
    for passes in (4, 64):
        img = caustica.render(cornell, integrator=integrator, spp=passes, seed=5)
        assert img.dtype == np.float32 and np.isfinite(img).all()
        e[passes] = relmse(img, cornell_ref)
    assert e[64] < 0.5 * e[4], e
    assert e[64] < 0.012, e


@pytest.mark.parametrize("integrator", ["bpm", "vcm"])
def test_consistent_ones_approach_path_tracing_on_smallvcm(smallvcm, smallvcm_path_regions, integrator):
    # Merging is biased by the radius, which shrinks as r_1 i^((alpha - 1)/2): the total energy is within
    # 2% of the path tracer's at 64 passes with a small radius (measured 0.3-1%), and the relMSE against
    # the path tracer's image falls from 8 to 64 passes.
    mr, _ = smallvcm_path_regions
    ref = caustica.render(smallvcm, spp=1024, seed=98, sampler="independent").astype(np.float64)
    e = {}
    for passes in (8, 64):
        img = caustica.render(smallvcm, integrator=integrator, spp=passes, seed=7, radius=0.02)
        e[passes] = relmse(img, ref)
    assert e[64] < 0.6 * e[8], e
    assert abs(img.mean() / mr.mean() - 1) < 0.02, img.mean() / mr.mean()


def sds_scene():
    """Every light path to the camera is L S S D S E: a point light inside a glass sphere lights a diffuse
    floor, and the camera sees the floor only in a large mirror."""
    return {
        "film": {"width": 32, "height": 32, "filter": "box"},
        "camera": {"position": [1.5, 0, 0.8], "target": [3, 0, 0.5], "up": [0, 0, 1], "fov": 30},
        "materials": {"white": {"type": "diffuse", "reflectance": 0.8},
                      "mirror": {"type": "conductor"},
                      "glass": {"type": "dielectric", "eta": 1.5}},
        "shapes": [{"type": "rectangle", "material": "white", "transform": {"scale": 4}},
                   {"type": "rectangle", "material": "mirror",
                    "transform": {"scale": 4, "rotate": {"axis": [0, 1, 0], "angle": -90}, "translate": [3, 0, 0]}},
                   {"type": "sphere", "center": [0, 0, 1], "radius": 0.3, "material": "glass"}],
        "lights": [{"type": "point", "position": [0, 0, 1], "intensity": 10}],
        "max_depth": 12,
    }


def test_vcm_renders_a_caustic_seen_in_a_mirror_which_bdpt_cannot():
    # L S S D S E only: bdpt has no strategy (a delta light behind a delta BSDF reaches the diffuse vertex,
    # which the camera sees only through a delta BSDF), so its image is exactly black, like the path
    # tracer's; vcm merges at the floor. vcm's mean agrees with SPPM's (another consistent estimator)
    # within 4 combined standard errors (4 seeds each) plus 5% for their different radius bias.
    s = caustica.load_scene(sds_scene())
    assert float(caustica.render(s, integrator="bdpt", spp=8).max()) == 0.0
    assert float(caustica.render(s, integrator="path", spp=8).max()) == 0.0
    v = [float(caustica.render(s, integrator="vcm", spp=16, seed=k).mean()) for k in range(4)]
    r = [float(caustica.render(s, integrator="sppm", spp=16, seed=k).mean()) for k in range(10, 14)]
    vm, vse = np.mean(v), np.std(v, ddof=1) / 2
    rm, rse = np.mean(r), np.std(r, ddof=1) / 2
    assert vm > 0.01, vm
    assert abs(vm - rm) < 4 * np.hypot(vse, rse) + 0.05 * rm, (vm, vse, rm, rse)


def test_vcm_adds_the_mirrored_caustic_on_the_smallvcm_point_scene():
    # SmallVCM's point-light scene: the glass sphere's caustic on the floor, seen in the mirror sphere
    # (a streak at rows 105-106, columns 51-53 of a 128x128 image). vcm (4 seeds x 8 passes, measured
    # 0.59 +- 0.02) exceeds bdpt's estimate there, which lacks the L S S D S E paths (measured 0.45 +- 0.09
    # over 4 seeds: its variance comes from rare light-tracing hits); SPPM measured 0.68 +- 0.10.
    # The assertion (vcm above bdpt's mean by 10%) is the weak form affordable in test time. The radius is
    # fixed at twice the pixel footprint (the default until 2026-11-22, with which the figures above were
    # measured); at the default of one footprint, 4 seeds x 8 passes gave 0.46 +- 0.02: a merge there sees
    # few light vertices and the estimate is right-skewed at 8 passes. At 128 passes (2 seeds) both agree:
    # 0.67 (one footprint), 0.64 (two), SPPM 0.66 at 256 passes.
    s = caustica.load_scene("smallvcm-point", width=128, height=128)
    reg = (slice(105, 107), slice(51, 54))
    v = np.mean([float(caustica.render(s, integrator="vcm", spp=8, seed=k, radius=0.0538)[reg].mean())
                 for k in (11, 12)])
    b = np.mean([float(caustica.render(s, integrator="bdpt", spp=8, seed=k)[reg].mean()) for k in (11, 12, 13, 14)])
    assert v > 1.1 * b, (v, b)


def test_light_tracing_furnace_point_light_over_diffuse_plane():
    # A diffuse plane (albedo a) under a point light of intensity I at height h, seen by the camera: the
    # radiance leaving a point at horizontal distance rho is L = a/pi * I cos / d^2, cos = h / d. Light
    # tracing estimates it from splats only (the point light is invisible to camera rays). Per region,
    # the analytic mean of L over the region's pixels agrees within 4 SE (16 seeds); measured within 3%.
    a, I, h = 0.6, 3.0, 1.0
    scene = plane_scene(a, I, h)
    s = caustica.load_scene(scene)
    m, se = seeded_regions(s, "light", 16, range(16), max_depth=2)
    # Analytic: the camera looks straight down from z = 2; each pixel's centre ray hits the plane at
    # (x, y); average L over a 4x4 sub-grid per pixel, then over the region.
    W = 24
    t = np.tan(np.radians(40) / 2)
    sub = (np.arange(4) + 0.5) / 4
    L = np.zeros((W, W))
    for i in range(W):
        for j in range(W):
            acc = 0.0
            for u in sub:
                for v in sub:
                    sx = (2 * (j + u) / W - 1) * t
                    sy = (1 - 2 * (i + v) / W) * t
                    x, y = 2.0 * sx, 2.0 * sy
                    d2 = x * x + y * y + h * h
                    acc += a / np.pi * I * (h / np.sqrt(d2)) / d2
            L[i, j] = acc / 16
    expect = regions(np.repeat(L[:, :, None], 3, axis=2))
    z = np.abs(m - expect) / se
    assert z.max() < 4.0, (np.round(z, 1), m / expect)


@pytest.mark.parametrize("integrator", BIDIR)
def test_deterministic_across_thread_counts(integrator):
    # Splats land in arbitrary pixels: they are added in light-path chunk order, so 1 and 2 threads give
    # the same bits.
    s = caustica.load_scene("smallvcm-spheres", width=40, height=32)
    a = caustica.render(s, integrator=integrator, spp=3, threads=1, seed=2)
    b = caustica.render(s, integrator=integrator, spp=3, threads=2, seed=2)
    assert np.array_equal(a, b)
    c = caustica.render(s, integrator=integrator, spp=3, threads=2, seed=3)
    assert not np.array_equal(a, c)


def test_thin_lens_light_tracing_matches_path_tracing():
    # The thin-lens camera: light tracing samples a lens point per splat, the path tracer per camera ray.
    # A sphere on the plane, focused in front of it (strong blur): region means within 4 combined SE.
    scene = plane_scene(0.6, 3.0, 1.0)
    scene["camera"].update({"aperture_radius": 0.15, "focus_distance": 1.2})
    scene["shapes"].append({"type": "sphere", "center": [0.3, 0.2, 0.3], "radius": 0.3, "material": "white"})
    s = caustica.load_scene(scene)
    m, se = seeded_regions(s, "light", 16, range(16), max_depth=2)
    mr, ser = seeded_regions(s, "path", 64, range(16), max_depth=2)
    z = np.abs(m - mr) / np.sqrt(se ** 2 + ser ** 2)
    assert z.max() < 4.0, (np.round(z, 1), m / mr)


# Per-strategy images (Veach 1997, Fig. 10.3): every weighted contribution lands in exactly one of them.
K_MAX = 7
N_STRATEGIES = sum(k + 1 for k in range(1, K_MAX + 1)) + (K_MAX - 1)


@pytest.mark.parametrize("integrator", ["bdpt", "vcm"])
def test_strategy_images_sum_to_the_image(integrator):
    # With max_depth <= 7 every path is in some strategy image: their sum is the image (float sums of the
    # same terms in another order: 1e-5 relative to the brightest pixel).
    s = caustica.load_scene("smallvcm-spheres", width=32, height=32)
    r = caustica.render_job(s, integrator=integrator, spp=4, max_depth=7, radius=0.05, strategy_images=True)
    assert len(r.strategies) == N_STRATEGIES
    assert set(r.strategies) >= {"k1_s0_t2", "k2_s1_t2", "k2_s2_t1", "k7_s7_t1", "merge_t2", "merge_t7"}
    total = sum(r.strategies.values())
    assert np.abs(total - r.image).max() <= 1e-5 * float(r.image.max())
    # Each kind of strategy contributes on this scene (emission, NEE, connections, light tracing; merges for vcm).
    means = {k: float(v.mean()) for k, v in r.strategies.items()}
    for k in ("k1_s0_t2", "k2_s1_t2", "k2_s2_t1", "k3_s2_t2"):
        assert means[k] > 0, (k, means[k])
    merged = sum(v for k, v in means.items() if k.startswith("merge"))
    assert (merged > 0) == (integrator == "vcm"), merged


def test_strategy_images_follow_the_integrators_strategy_set():
    # light: only light tracing (t = 1) and the camera rays through delta chains that hit a light (s = 0);
    # bpm: merges and s = 0 only. Images of other strategies are exactly zero.
    s = caustica.load_scene("smallvcm-spheres", width=24, height=24)
    light = caustica.render_job(s, integrator="light", spp=2, max_depth=6, strategy_images=True).strategies
    for k, v in light.items():
        if not (k.endswith("_t1") or "_s0_" in k):
            assert float(np.abs(v).max()) == 0.0, k
    assert float(light["k3_s3_t1"].mean()) > 0
    bpm = caustica.render_job(s, integrator="bpm", spp=2, max_depth=6, radius=0.05, strategy_images=True).strategies
    for k, v in bpm.items():
        if not (k.startswith("merge") or "_s0_" in k):
            assert float(np.abs(v).max()) == 0.0, k
    assert float(bpm["merge_t2"].mean()) > 0


def test_strategy_images_are_refused_for_other_integrators():
    with pytest.raises(caustica.InputError, match="strategy-images needs a bidirectional integrator"):
        caustica.render_job("cornell", integrator="path", spp=1, strategy_images=True)


def test_cli_writes_strategy_images(caustica_bin, tmp_path):
    import subprocess
    d = tmp_path / "strategies"
    d.mkdir()
    out = str(tmp_path / "img.exr")
    r = subprocess.run([caustica_bin, "render", "cornell", "--integrator", "bdpt", "--spp", "1", "--width", "16",
                        "--height", "16", "--max-depth", "3", "--quiet", "-o", out, "--strategy-images", str(d)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    names = sorted(os.listdir(d))
    assert len(names) == N_STRATEGIES and "k2_s1_t2.exr" in names
    total = sum(caustica.read_image(str(d / n)) for n in names)
    img = caustica.read_image(out)
    assert np.abs(total - img).max() <= 1e-5 * float(img.max())
    for bad in (["--strategy-images", str(tmp_path / "missing")], ["--strategy-images", str(d), "--integrator", "path"]):
        r = subprocess.run([caustica_bin, "render", "cornell", "--spp", "1", "--width", "8", "--height", "8", "--quiet",
                            "-o", str(tmp_path / "x.exr"), *bad], capture_output=True, text=True, timeout=60)
        assert r.returncode == 2 and "strategy-images" in r.stderr and "Traceback" not in r.stderr, r.stderr
        assert not os.path.exists(tmp_path / "x.exr")
