"""`caustica compare A B`: one line per metric or JSON, the same numbers as caustica.metrics, an
error-map file, and bad input as one line on stderr with exit status 2 and no file written."""
import json
import os
import subprocess

import numpy as np
import pytest

import caustica
import caustica.metrics as M


def run(bin, *args):
    return subprocess.run([bin, *args], capture_output=True, text=True, timeout=120)


@pytest.fixture
def pair(tmp_path):
    rng = np.random.default_rng(5)
    y, x = np.mgrid[0:32, 0:40] / 40.0
    ref = np.stack([0.2 + 0.6 * x, 0.3 + 0.5 * y, 0.4 + 0.0 * x], axis=2).astype(np.float32)
    img = np.clip(ref + rng.normal(0, 0.05, ref.shape), 0, None).astype(np.float32)
    caustica.write_image(str(tmp_path / "img.exr"), img)
    caustica.write_image(str(tmp_path / "ref.exr"), ref)
    return str(tmp_path / "img.exr"), str(tmp_path / "ref.exr"), img, ref


def test_prints_one_line_per_metric(caustica_bin, pair):
    a, b, img, ref = pair
    r = run(caustica_bin, "compare", a, b)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert [ln.split()[0] for ln in lines] == ["mse", "rmse", "relmse", "mape", "ssim", "flip"]
    want = M.evaluate(img, ref)
    for ln in lines:
        name, value = ln.split()[:2]
        assert float(value) == pytest.approx(want[name], rel=1e-5)
    assert "(eps 0.01)" in lines[2]
    assert r.stderr == ""


def test_json_and_metric_choice(caustica_bin, pair):
    a, b, img, ref = pair
    r = run(caustica_bin, "compare", a, b, "--metrics", "relmse,flip-hdr", "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert list(d) == ["relmse", "flip-hdr"]
    assert d["relmse"] == pytest.approx(M.relmse(img, ref), rel=1e-12)
    assert d["flip-hdr"] == pytest.approx(M.flip(img, ref, mode="hdr"), rel=1e-12)


def test_png_against_exr_reference(caustica_bin, pair, tmp_path):
    a, b, img, ref = pair
    caustica.write_image(str(tmp_path / "img.png"), img)
    r = run(caustica_bin, "compare", str(tmp_path / "img.png"), b, "--metrics", "mse", "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["mse"] == pytest.approx(M.mse(str(tmp_path / "img.png"), ref))


@pytest.mark.parametrize("metric", ["flip", "relmse"])
def test_error_map_png(caustica_bin, pair, tmp_path, metric):
    a, b, _, _ = pair
    out = str(tmp_path / "err.png")
    r = run(caustica_bin, "compare", a, b, "--metrics", "mse", "--error-map", out, "--map-metric", metric)
    assert r.returncode == 0, r.stderr
    assert open(out, "rb").read(8) == b"\x89PNG\r\n\x1a\n"
    assert M.read(out).shape == (32, 40, 3)
    assert f"error map: {metric} per pixel, magma, 0 .. " in r.stderr and out in r.stderr
    if metric == "flip":
        assert "0 .. 1 ->" in r.stderr  # FLIP's range is fixed


def test_error_map_exr_holds_the_values(caustica_bin, pair, tmp_path):
    a, b, img, ref = pair
    out = str(tmp_path / "err.exr")
    r = run(caustica_bin, "compare", a, b, "--error-map", out, "--map-metric", "relmse", "--json")
    assert r.returncode == 0, r.stderr
    json.loads(r.stdout)
    np.testing.assert_allclose(caustica.read_image(out)[..., 0], M.error_map(img, ref, "relmse"), rtol=1e-6)


BAD = [
    (["{d}/nope.exr", "{d}/ref.exr"], "cannot read '{d}/nope.exr': no such file"),
    (["{d}/img.exr", "{d}/ref.jpg"], "unknown image format '.jpg' (allowed: .exr, .pfm, .png, .npy, .npz)"),
    (["{d}/img.exr", "{d}/small.exr"], "images differ in size: 40x32 vs 8x8"),
    (["{d}/img.exr", "{d}/ref.exr", "--metrics", "relmse,psnr"], "unknown metric 'psnr' (allowed: mse, rmse"),
    (["{d}/img.exr", "{d}/ref.exr", "--metrics", ","], "no metrics given"),
    (["{d}/img.exr", "{d}/ref.exr", "--error-map", "{d}/e.png", "--map-metric", "ssim"],
     "unknown error map 'ssim' (allowed: mse, relmse, mape, flip, flip-hdr)"),
    (["{d}/img.exr", "{d}/ref.exr", "--error-map", "{d}/e.tif"], "unknown output format '.tif'"),
    (["{d}/img.exr", "{d}/ref.exr", "--error-map", "{d}/missing/e.png"], "does not exist"),
    (["{d}/img.exr", "{d}/ref.exr", "--exposure", "bright"], "--exposure expects a finite number, got 'bright'"),
    (["{d}/img.exr"], "the following arguments are required: B"),
    (["{d}/img.exr", "{d}/garbage.png"], "cannot read '{d}/garbage.png': not a PNG file"),
]


@pytest.mark.parametrize("args,needle", BAD, ids=[b[1][:40] for b in BAD])
def test_bad_input(caustica_bin, pair, tmp_path, args, needle):
    caustica.write_image(str(tmp_path / "small.exr"), np.zeros((8, 8, 3), np.float32))
    (tmp_path / "garbage.png").write_bytes(b"GIF89a")
    before = set(os.listdir(tmp_path))
    d = str(tmp_path)
    r = run(caustica_bin, "compare", *[x.format(d=d) for x in args])
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert lines[0].startswith("caustica: error: ")
    assert needle.format(d=d) in lines[0], lines[0]
    assert r.stdout == ""
    assert set(os.listdir(tmp_path)) == before
