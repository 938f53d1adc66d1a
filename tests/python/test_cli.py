"""The command line: it renders and writes each format, and rejects each kind of bad input
with one line on stderr, exit status 2, no traceback and no output file."""
import json
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import caustica


def run(bin, *args, cwd=None, timeout=120):
    return subprocess.run([bin, *args], capture_output=True, text=True, cwd=cwd, timeout=timeout)


def test_version_and_scenes(caustica_bin):
    r = run(caustica_bin, "--version")
    assert r.returncode == 0 and r.stdout.strip() == f"caustica {caustica.__version__}"
    r = run(caustica_bin, "scenes")
    assert r.returncode == 0
    assert r.stdout.splitlines()[0].startswith("smallvcm-spheres")
    assert "cornell " in r.stdout


def test_no_lanes_renders_the_same_image(caustica_bin, tmp_path):
    outs = [str(tmp_path / f"{n}.exr") for n in ("lanes", "nolanes")]
    base = ["render", "cornell", "--spp", "3", "--width", "36", "--height", "20", "--quiet", "--seed", "4"]
    for o, extra in zip(outs, ([], ["--no-lanes"])):
        r = run(caustica_bin, *base, *extra, "-o", o)
        assert r.returncode == 0, r.stderr
    assert np.array_equal(caustica.read_image(outs[0]), caustica.read_image(outs[1]))


def test_accel_small_refuses_a_larger_scene(caustica_bin, tmp_path):
    scene = tmp_path / "cubes.json"
    scene.write_text(json.dumps({"camera": {"position": [0, 0, 30], "target": [0, 0, 0]},
                                 "shapes": [{"type": "cube", "transform": {"translate": [2.5 * i - 12.5, 0, 0]}}
                                            for i in range(11)],
                                 "lights": [{"type": "environment", "radiance": 1}]}))
    out = tmp_path / "o.exr"
    r = run(caustica_bin, "render", str(scene), "--spp", "1", "--width", "8", "--height", "8", "--quiet",
            "--accel", "small", "-o", str(out))
    assert r.returncode == 2 and "--accel small takes scenes of at most 128 triangles" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not out.exists()
    r = run(caustica_bin, "render", str(scene), "--spp", "1", "--width", "8", "--height", "8", "--quiet",
            "--accel", "kd", "-o", str(out))
    assert r.returncode == 2 and "auto, embree, small, bvh" in r.stderr, r.stderr
    r = run(caustica_bin, "render", str(scene), "--spp", "1", "--width", "8", "--height", "8", "--quiet",
            "--accel", "auto", "-o", str(out))
    assert r.returncode == 0 and out.exists(), r.stderr


def test_render_writes_each_format(caustica_bin, tmp_path):
    outs = [str(tmp_path / f"img.{e}") for e in ("exr", "pfm", "png")]
    args = ["render", "cornell", "--spp", "2", "--width", "32", "--height", "24", "--quiet"]
    for o in outs:
        args += ["-o", o]
    r = run(caustica_bin, *args)
    assert r.returncode == 0, r.stderr
    exr, pfm = caustica.read_image(outs[0]), caustica.read_image(outs[1])
    assert exr.shape == (24, 32, 3) and np.array_equal(exr, pfm)
    # Same seed from the API: the same image.
    api = caustica.render(caustica.load_scene("cornell", width=32, height=24), spp=2)
    assert np.array_equal(api, exr)
    assert open(outs[2], "rb").read(4) == b"\x89PNG"
    assert sorted(os.listdir(tmp_path)) == ["img.exr", "img.pfm", "img.png"]


def test_progress_bar_shows_rate(caustica_bin, tmp_path):
    r = run(caustica_bin, "render", "cornell", "--spp", "4", "--width", "32", "--height", "32",
            "-o", str(tmp_path / "a.exr"))
    assert r.returncode == 0
    assert "samples/s" in r.stderr and "rendering" in r.stderr


BAD = [
    (["render", "nope", "-o", "{d}/a.exr"], "unknown scene 'nope'"),
    (["render", "cornell", "--integrator", "xyz", "-o", "{d}/a.exr"], "unknown integrator 'xyz' (allowed: path, sppm, ppm, pppm, pm, light, bdpt, bpm, vcm, upg, restir)"),
    (["render", "cornell", "--spp", "abc", "-o", "{d}/a.exr"], "--spp expects a positive integer, got 'abc'"),
    (["render", "cornell", "--spp", "0", "-o", "{d}/a.exr"], "--spp expects a positive integer"),
    (["render", "cornell", "--time", "-2", "-o", "{d}/a.exr"], "--time expects a positive number"),
    (["render", "cornell", "--width", "1.5", "-o", "{d}/a.exr"], "--width expects a positive integer"),
    (["render", "cornell", "--max-depth", "0", "-o", "{d}/a.exr"], "--max-depth expects"),
    (["render", "cornell", "--filter", "bicubic", "-o", "{d}/a.exr"], "unknown filter 'bicubic' (allowed: box, tent, gaussian, mitchell, catmullrom, lanczos)"),
    (["render", "cornell", "--sampler", "halton", "-o", "{d}/a.exr"], "unknown sampler 'halton'"),
    (["render", "cornell", "--frobnicate", "-o", "{d}/a.exr"], "unrecognized arguments: --frobnicate"),
    (["render", "cornell", "-o", "{d}/a.jpg"], "unknown output format '.jpg' (allowed: .exr, .pfm, .png)"),
    (["render", "cornell", "-o", "{d}/missing/a.exr"], "does not exist"),
    (["render", "{d}/nothere.json", "-o", "{d}/a.exr"], "no such file"),
    (["render", "{d}/bad.json", "-o", "{d}/a.exr"], "bad.json:3: invalid JSON"),
    (["render", "{d}/badval.json", "-o", "{d}/a.exr"], "badval.json: /camera/fov: expected a number, got string"),
    (["render", "{d}/scene.stl", "-o", "{d}/a.exr"], "unsupported scene format '.stl'"),
    (["render", "{d}/meshfile.json", "-o", "{d}/a.exr"],
     "meshfile.json: /shapes/0/file: mesh file 'gone.ply' does not exist"),
    (["render", "{d}/cams.json", "--camera", "top", "-o", "{d}/a.exr"], "no camera named 'top' (cameras: front, side)"),
    (["render", "cornell", "--param", "spp", "-o", "{d}/a.exr"], "--param expects NAME=VALUE, got 'spp'"),
    (["info", "{d}/badval.json"], "badval.json: /camera/fov: expected a number, got string"),
    (["info"], "the following arguments are required: scene"),
    (["info", "nope"], "unknown scene 'nope'"),
    (["export", "cornell"], "the following arguments are required: -o/--output"),
    (["export", "cornell", "-o", "{d}/a.txt"], "scenes are exported as .json"),
    (["export", "cornell", "-o", "{d}/missing/a.json"], "does not exist"),
    (["export", "{d}/bad.json", "-o", "{d}/a.json"], "bad.json:3: invalid JSON"),
    (["explode"], "invalid choice: 'explode'"),
]


@pytest.mark.parametrize("args,needle", BAD, ids=[b[1][:40] for b in BAD])
def test_bad_input(caustica_bin, tmp_path, args, needle):
    (tmp_path / "bad.json").write_text('{\n "camera": {},\n "shapes": [}\n}\n')
    (tmp_path / "badval.json").write_text('{"camera": {"fov": "wide"}, "shapes": [{"type": "cube"}]}')
    (tmp_path / "scene.stl").write_text("solid x\n")
    (tmp_path / "meshfile.json").write_text('{"camera": {}, "shapes": [{"type": "mesh", "file": "gone.ply"}]}')
    (tmp_path / "cams.json").write_text('{"cameras": {"front": {}, "side": {"position": [1, 0, 0]}}, '
                                        '"shapes": [{"type": "cube"}]}')
    before = set(os.listdir(tmp_path))
    r = run(caustica_bin, *[a.format(d=tmp_path) for a in args])
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert needle in lines[0], lines[0]
    assert "Traceback" not in r.stderr
    assert set(os.listdir(tmp_path)) == before  # no partial or temporary file


def test_unwritable_directory(caustica_bin, tmp_path):
    if os.geteuid() == 0:
        # root writes anywhere; a path under a regular file is unwritable for everyone.
        (tmp_path / "file").write_text("x")
        target = str(tmp_path / "file" / "a.exr")
    else:
        d = tmp_path / "ro"
        d.mkdir()
        d.chmod(0o500)
        target = str(d / "a.exr")
    r = run(caustica_bin, "render", "cornell", "--spp", "1", "-o", target)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "cannot write" in r.stderr


def test_ctrl_c_writes_what_it_has(caustica_bin, tmp_path):
    out = tmp_path / "partial.exr"
    p = subprocess.Popen([caustica_bin, "render", "cornell", "--time", "60", "--quiet", "-o", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(3.0)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    img = caustica.read_image(out)
    assert img.shape == (256, 256, 3) and np.isfinite(img).all() and img.mean() > 0.1
    assert sorted(os.listdir(tmp_path)) == ["partial.exr"]


def test_devices_and_the_device_option(caustica_bin, tmp_path):
    # `caustica devices` lists the CPU and every usable CUDA device, or says why there is none; an unknown
    # device, and cuda where there is no GPU, are one clear line with exit status 2 and no output file.
    r = run(caustica_bin, "devices")
    assert r.returncode == 0 and r.stdout.startswith("cpu "), r.stdout
    cuda, why = caustica.cuda_status()
    names = [d["name"] for d in caustica.devices()]
    assert names == ["cpu"] + [f"cuda:{d['index']}" for d in cuda]
    if not cuda:
        assert why and f"cuda   not available: {why}" in r.stdout, r.stdout
    out = tmp_path / "img.exr"
    bad = [("tpu", "unknown device 'tpu' (allowed: cpu, cuda, cuda:N)"),
           ("cuda:99", "device 'cuda:99' " + ("does not exist" if cuda else "is not available"))]
    if not cuda:
        bad.append(("cuda", "device 'cuda' is not available"))
    for dev, msg in bad:
        r = run(caustica_bin, "render", "cornell", "--spp", "1", "--width", "8", "--height", "8", "--quiet",
                "--device", dev, "-o", str(out))
        assert r.returncode == 2 and msg in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
        assert not out.exists()
        with pytest.raises(caustica.InputError, match=re.escape(msg.split(" (")[0])):
            caustica.render("cornell", spp=1, device=dev)
    r = run(caustica_bin, "render", "cornell", "--spp", "1", "--width", "8", "--height", "8", "--quiet",
            "--device", "cpu", "-o", str(out))
    assert r.returncode == 0 and out.exists(), r.stderr


def test_a_closed_pipe_ends_quietly(caustica_bin):
    # `caustica info cornell | head -1`: the reader is gone before anything is written (its end is closed
    # at once); caustica stops with exit status 141 (128 + SIGPIPE, as a shell reports a tool killed by it)
    # and no traceback.
    p = subprocess.Popen([caustica_bin, "info", "cornell"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=60) == 141 and "Traceback" not in err, err
