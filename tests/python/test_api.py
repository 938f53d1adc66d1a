import os
import threading

import numpy as np
import pytest

import caustica


def test_render_returns_float32_hw3():
    img = caustica.render("cornell", spp=2)
    assert img.dtype == np.float32 and img.shape == (256, 256, 3)
    assert np.isfinite(img).all() and img.mean() > 0


def test_load_scene_overrides_and_info():
    s = caustica.load_scene("smallvcm-spheres", width=40, height=30, filter="tent")
    assert (s.width, s.height, s.filter) == (40, 30, "tent")
    assert s.num_spheres == 2 and s.num_lights == 2
    names = [n for n, _ in caustica.builtin_scenes()]
    assert names[0] == caustica.default_scene_name() == "smallvcm-spheres"
    assert {"cornell", "smallvcm-sun", "smallvcm-mirror-ball", "smallvcm-point", "smallvcm-env"} <= set(names)


@pytest.mark.parametrize("name", ["smallvcm-sun", "smallvcm-mirror-ball", "smallvcm-point", "smallvcm-env", "smallvcm-fog"])
def test_every_builtin_renders(name):
    img = caustica.render(caustica.load_scene(name, width=32, height=32), spp=2)
    assert np.isfinite(img).all() and img.mean() > 0


def test_progress_called_and_can_stop():
    calls = []
    img = caustica.render(caustica.load_scene("cornell", width=64, height=64), spp=64,
                          progress=lambda st: calls.append(dict(st)))
    assert calls and calls[-1]["passes"] == 64 and calls[-1]["done"]
    r = caustica.render_job(caustica.load_scene("cornell", width=64, height=64), spp=100000,
                            progress=lambda st: False)
    assert 0 < r.stats["passes"] < 100000 and r.stats["cancelled"]
    assert np.isfinite(r.image).all() and r.image.mean() > 0


def test_gil_released_while_rendering():
    ticks = []
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            ticks.append(1)
            stop.wait(0.001)

    t = threading.Thread(target=spin)
    t.start()
    try:
        caustica.render(caustica.load_scene("cornell", width=128, height=128), spp=32)
    finally:
        stop.set()
        t.join()
    assert len(ticks) > 10


def test_write_and_read_back(tmp_path):
    img = caustica.render(caustica.load_scene("cornell", width=20, height=10), spp=2)
    for ext in ("exr", "pfm"):
        p = tmp_path / f"a.{ext}"
        caustica.write_image(p, img)
        back = caustica.read_image(p)
        assert back.shape == img.shape and np.array_equal(back, img)
    caustica.write_image(tmp_path / "a.png", img, exposure=1.0)
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [f for f in os.listdir(tmp_path) if "tmp" in f]


@pytest.mark.parametrize("kwargs,needle", [
    (dict(integrator="nope"), "unknown integrator 'nope'"),
    (dict(spp=0), "spp must be a positive integer"),
    (dict(spp=-3), "spp must be a positive integer"),
    (dict(time=-1.0), "time must be a positive number"),
    (dict(max_depth=0), "max_depth must be a positive integer"),
    (dict(sampler="halton"), "unknown sampler 'halton'"),
    (dict(accel="optix"), "unknown accelerator 'optix'"),
    (dict(threads=-1), "threads must be a non-negative integer"),
])
def test_bad_render_arguments(kwargs, needle):
    with pytest.raises(caustica.InputError, match=needle):
        caustica.render("cornell", **kwargs)


def test_bad_scenes():
    with pytest.raises(caustica.InputError, match="unknown scene 'nope'.*cornell"):
        caustica.load_scene("nope")
    with pytest.raises(caustica.InputError, match="no such file"):
        caustica.load_scene("missing/scene.json")
    with pytest.raises(caustica.InputError, match=r"<dict>: /shapes/0/radius: expected a number, got string"):
        caustica.load_scene({"camera": {}, "shapes": [{"type": "sphere", "radius": "big"}]})
    with pytest.raises(caustica.InputError, match=r"<dict>: /materials/m/type: unknown material type 'velvet'"):
        caustica.load_scene({"camera": {}, "materials": {"m": {"type": "velvet"}}, "shapes": [{"type": "cube"}]})
    with pytest.raises(caustica.InputError, match=r"/shapes/0/material: no material named 'x'"):
        caustica.load_scene({"camera": {}, "shapes": [{"type": "cube", "material": "x"}]})
    with pytest.raises(caustica.InputError, match="unknown filter"):
        caustica.load_scene("cornell", filter="bicubic")
    with pytest.raises(caustica.InputError, match="width must be a positive integer"):
        caustica.load_scene("cornell", width=0)


def test_bad_json_file_names_line(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text('{\n  "camera": {},\n  "shapes": [\n    {"type": "cube",,}\n  ]\n}\n')
    with pytest.raises(caustica.InputError, match=r"bad\.json:4: invalid JSON"):
        caustica.load_scene(p)


def test_unsupported_output(tmp_path):
    img = np.zeros((2, 2, 3), np.float32)
    with pytest.raises(caustica.InputError, match=r"unknown output format '\.jpg'"):
        caustica.write_image(tmp_path / "a.jpg", img)
    with pytest.raises(caustica.InputError, match="does not exist"):
        caustica.write_image(tmp_path / "no" / "a.exr", img)


def test_scene_loading_api_surface():
    s = caustica.load_scene({"camera": {"width": 8, "height": 6}, "shapes": [{"type": "cube"}]})
    assert isinstance(s, caustica.Scene) and (s.width, s.height) == (8, 6)
    assert caustica.load_scene(s) is s
    assert set(s.describe()) >= {"shapes", "meshes", "triangles", "spheres", "materials", "lights", "area_lights",
                                 "textures", "bounds"}
    assert issubclass(caustica.SceneError, caustica.InputError)
    with pytest.raises(caustica.InputError, match="already loaded"):
        caustica.load_scene(s, camera="x")
    with pytest.raises(caustica.InputError, match="params: expected a dict"):
        caustica.load_scene("cornell", params=["spp=4"])
    with pytest.raises(caustica.InputError, match="camera: expected a camera name"):
        caustica.load_scene("cornell", camera=3)
    with pytest.raises(caustica.SceneError, match="no camera named 'x'"):
        caustica.load_scene("cornell", camera="x")


@pytest.mark.parametrize("lanes", [True, False])
def test_snapshot_counters_match_its_image(lanes):
    # RenderJob.snapshot() copies the image and reads the counters under the film's lock, between passes:
    # samples is always whole passes of pixels, and the image is that of those passes. stats() read after
    # image() could already count tiles of the next pass (a 16x16 tile of a 32x32 image: 1/4 pass).
    s = caustica.load_scene("cornell", width=32, height=32)
    job = caustica._native.RenderJob(s, integrator="path", spp=0, time=1.0, seed=2, lanes=lanes)
    job.start()
    snaps = []
    while not job.wait(0.0):
        img, st = job.snapshot()
        assert st["samples"] == st["passes"] * 32 * 32, st
        snaps.append((st["passes"], img))
    assert len({p for p, _ in snaps}) >= 3  # snapshots at several pass counts
    # The image at a pass count is the one a fresh render of that many passes gives.
    p, img = next((p, i) for p, i in snaps if p > 0)
    again = caustica.render(s, integrator="path", spp=p, seed=2, lanes=lanes)
    assert np.array_equal(img, again)


def _eleven_cubes():
    # 132 triangles: more than the small-scene test takes (128).
    return caustica.load_scene({"camera": {"position": [0, 0, 30], "target": [0, 0, 0]},
                                "shapes": [{"type": "cube", "transform": {"translate": [2.5 * i - 12.5, 0, 0]}}
                                           for i in range(11)],
                                "lights": [{"type": "environment", "radiance": 1}]}, width=8, height=8)


def test_accelerator_choice():
    # "auto" takes the small-scene test on scenes of at most 128 triangles where the CPU has AVX2 (the lanes
    # need AVX2 too, so stats["lanes"] tells), Embree on larger ones; every name is reported as used.
    s = caustica.load_scene("cornell", width=16, height=16)
    auto = caustica.render_job(s, spp=1)
    assert auto.stats["accel"] == ("small" if auto.stats["lanes"] == 8 else "embree")
    for accel in ("embree", "bvh"):
        assert caustica.render_job(s, spp=1, accel=accel).stats["accel"] == accel
    big = _eleven_cubes()
    assert caustica.render_job(big, spp=1).stats["accel"] == "embree"
    with pytest.raises(caustica.InputError, match="--accel small takes scenes of at most 128 triangles and 8 "
                                                  "spheres without cut-outs \\(opacity\\) on a CPU with AVX2; this one has 132 triangles"):
        caustica.render_job(big, spp=1, accel="small")


def test_small_scene_test_and_embree_estimate_the_same_image():
    # The two accelerators round hit points differently (by an ulp), so paths part ways now and then; their
    # images are estimates of the same image: the mean over pixels of the paired difference (8 seeds, one
    # render each) is within 4 standard errors of 0.
    s = caustica.load_scene("cornell", width=32, height=32)
    if caustica.render_job(s, spp=1).stats["accel"] != "small":
        pytest.skip("this CPU lacks AVX2, which the small-scene test needs")
    diffs = [caustica.render(s, spp=8, seed=k, accel="small").mean() - caustica.render(s, spp=8, seed=k, accel="embree").mean()
             for k in range(8)]
    m, se = np.mean(diffs), np.std(diffs, ddof=1) / np.sqrt(len(diffs))
    assert abs(m) < 4 * se + 1e-7, (m, se)
