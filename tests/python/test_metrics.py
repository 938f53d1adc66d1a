"""caustica.metrics: each metric against values worked out by hand on tiny images, SSIM against a
direct window-by-window computation, FLIP's zero and monotonicity, error maps, and reading
every supported format with exact messages for bad input."""
import math
import os
import struct
import zlib

import numpy as np
import pytest

import caustica
import caustica.metrics as M
from caustica import InputError

# 2x2 grey: differences 0, -1, 0, 2 against references 0, 2, 2, 2.
X = np.array([[0.0, 1.0], [2.0, 4.0]])
R = np.array([[0.0, 2.0], [2.0, 2.0]])


def test_module_is_exported():
    assert caustica.metrics is M
    assert "metrics" in caustica.__all__
    assert M.METRICS == ("mse", "rmse", "relmse", "mape", "ssim", "flip", "flip-hdr")


def test_mse_rmse_relmse_mape_by_hand_2x2():
    assert M.mse(X, R) == pytest.approx((0 + 1 + 0 + 4) / 4)
    assert M.rmse(X, R) == pytest.approx(math.sqrt(1.25))
    # (x - r)^2 / (r^2 + 0.01): 0/0.01, 1/4.01, 0/4.01, 4/4.01
    assert M.relmse(X, R) == pytest.approx((1 / 4.01 + 4 / 4.01) / 4)
    assert M.relmse(X, R, eps=1.0) == pytest.approx((1 / 5 + 4 / 5) / 4)
    # |x - r| / (|r| + 0.01): 0, 1/2.01, 0, 2/2.01
    assert M.mape(X, R) == pytest.approx((1 / 2.01 + 2 / 2.01) / 4)
    for f in (M.mse, M.rmse, M.relmse, M.mape, M.ssim, M.flip):
        assert type(f(X, R)) is float


def test_metrics_by_hand_3x3_rgb():
    ref = np.ones((3, 3, 3))
    img = ref.copy()
    img[0, 0, 0], img[1, 2, 1], img[2, 2, 2] = 3.0, 0.0, 1.5  # differences 2, -1, 0.5 among 27 values
    assert M.mse(img, ref) == pytest.approx((4 + 1 + 0.25) / 27)
    assert M.rmse(img, ref) == pytest.approx(math.sqrt(5.25 / 27))
    assert M.relmse(img, ref) == pytest.approx(5.25 / 1.01 / 27)
    assert M.mape(img, ref) == pytest.approx(3.5 / 1.01 / 27)
    assert M.mse(ref, ref) == 0.0 and M.relmse(ref, ref) == 0.0 and M.mape(ref, ref) == 0.0
    # The project's relMSE (conftest) is the same number.
    from conftest import relmse
    rng = np.random.default_rng(1)
    a, b = rng.random((5, 7, 3)).astype(np.float32), rng.random((5, 7, 3)).astype(np.float32)
    assert M.relmse(a, b) == pytest.approx(relmse(a, b), rel=1e-6)


def test_evaluate_returns_the_same_numbers_in_order():
    v = M.evaluate(X, R)
    assert list(v) == ["mse", "rmse", "relmse", "mape", "ssim", "flip"]
    assert v["mse"] == M.mse(X, R) and v["relmse"] == M.relmse(X, R) and v["flip"] == M.flip(X, R)
    v = M.evaluate(X, R, ("flip-hdr", "mape"))
    assert list(v) == ["flip-hdr", "mape"] and v["flip-hdr"] == M.flip(X, R, mode="hdr")


# ---- SSIM


def _ssim_direct(a, b):
    """Window by window, straight from Wang et al. 2004 with an 11x11 Gaussian (sigma 1.5)."""
    def luma(img):
        e = M.srgb_encode(img)
        return 0.2126 * e[..., 0] + 0.7152 * e[..., 1] + 0.0722 * e[..., 2]
    x, y = luma(a), luma(b)
    h, w = x.shape
    ny, nx = min(11, h), min(11, w)
    gy = np.exp(-((np.arange(ny) - (ny - 1) / 2) ** 2) / 4.5)
    gx = np.exp(-((np.arange(nx) - (nx - 1) / 2) ** 2) / 4.5)
    win = np.outer(gy, gx)
    win /= win.sum()
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    vals = []
    for i in range(h - ny + 1):
        for j in range(w - nx + 1):
            px, py = x[i:i + ny, j:j + nx], y[i:i + ny, j:j + nx]
            mx, my = (win * px).sum(), (win * py).sum()
            vx, vy = (win * (px - mx) ** 2).sum(), (win * (py - my) ** 2).sum()
            cxy = (win * (px - mx) * (py - my)).sum()
            vals.append((2 * mx * my + c1) * (2 * cxy + c2) / ((mx ** 2 + my ** 2 + c1) * (vx + vy + c2)))
    return np.mean(vals)


def test_ssim_of_an_image_with_itself_is_one():
    rng = np.random.default_rng(2)
    a = rng.random((16, 20, 3))
    assert M.ssim(a, a) == pytest.approx(1.0, abs=1e-12)


def test_ssim_constant_images_by_hand():
    c1 = 0.01 ** 2
    # Black against white (linear >= 1 shows as 1): only the luminance term, C1 / (1 + C1).
    assert M.ssim(np.zeros((12, 12)), np.full((12, 12), 3.0)) == pytest.approx(c1 / (1 + c1))
    # Two flat greys: (2 e1 e2 + C1) / (e1^2 + e2^2 + C1) of their sRGB encodings.
    e1, e2 = 1.055 * 0.5 ** (1 / 2.4) - 0.055, 1.055 * 0.2 ** (1 / 2.4) - 0.055
    want = (2 * e1 * e2 + c1) / (e1 ** 2 + e2 ** 2 + c1)
    assert M.ssim(np.full((13, 11, 3), 0.5), np.full((13, 11, 3), 0.2)) == pytest.approx(want)
    assert M.ssim(np.full((3, 3), 0.5), np.full((3, 3), 0.2)) == pytest.approx(want)  # smaller than the window


@pytest.mark.parametrize("shape", [(14, 13, 3), (11, 11, 3), (5, 4, 3)])
def test_ssim_matches_the_direct_computation(shape):
    rng = np.random.default_rng(3)
    a = rng.random(shape).astype(np.float32)  # images are float32: compare like with like
    b = np.clip(a + rng.normal(0, 0.1, shape), 0, None).astype(np.float32)
    assert M.ssim(b, a) == pytest.approx(_ssim_direct(b, a), rel=1e-10)
    assert M.ssim_map(b, a).shape == (max(1, shape[0] - 10), max(1, shape[1] - 10))


def test_ssim_tonemaps_with_exposure():
    # Exposure -1 halves both images before clamping: 1.6 and 1.2 differ once they are below 1.
    a, b = np.full((12, 12), 1.6), np.full((12, 12), 1.2)
    assert M.ssim(a, b) == 1.0
    assert M.ssim(a, b, exposure=-1) < 0.999


# ---- FLIP


def _smooth_image(h=64, w=64):
    y, x = np.mgrid[0:h, 0:w] / 64.0
    return np.stack([0.1 + 0.6 * x, 0.2 + 0.5 * y, 0.3 + 0.3 * np.sin(6 * x * y) ** 2], axis=2)


@pytest.mark.parametrize("mode", ["ldr", "hdr"])
def test_flip_of_an_image_with_itself_is_zero(mode):
    a = _smooth_image()
    assert M.flip(a, a, mode=mode) == 0.0
    assert np.all(M.error_map(a, a, "flip" if mode == "ldr" else "flip-hdr") == 0)


@pytest.mark.parametrize("mode", ["ldr", "hdr"])
def test_flip_grows_with_noise(mode):
    ref = _smooth_image()
    rng = np.random.default_rng(7)
    noise = rng.normal(0.0, 1.0, ref.shape)
    values = [M.flip(np.clip(ref + s * noise, 0, None), ref, mode=mode) for s in (0.01, 0.03, 0.1, 0.3)]
    assert all(0 < v <= 1 for v in values), values
    assert all(b > a for a, b in zip(values, values[1:])), values


def test_ldr_flip_is_flip_of_the_display_images():
    import flip_evaluator
    ref = _smooth_image() * 1.5  # some values above 1: clamped, as in the PNG
    img = ref * 0.8
    enc = lambda v: np.ascontiguousarray(M.srgb_encode(v), dtype=np.float32)
    _, want, _ = flip_evaluator.evaluate(enc(ref), enc(img), "LDR", applyMagma=False)
    assert M.flip(img, ref) == pytest.approx(want, rel=1e-6)
    assert M.flip(img, ref) == pytest.approx(float(M.error_map(img, ref, "flip").mean()), rel=1e-6)


def test_hdr_flip_black_reference():
    z = np.zeros((16, 16, 3))
    assert M.flip(z, z, mode="hdr") == 0.0
    assert M.flip(z + 0.3, z, mode="hdr") > 0.5
    assert M.error_map(z + 0.3, z, "flip-hdr").shape == (16, 16)


def test_flip_bad_mode():
    with pytest.raises(InputError) as e:
        M.flip(X, R, mode="sdr")
    assert str(e.value) == "unknown FLIP mode 'sdr' (allowed: ldr, hdr)"


# ---- error maps


def test_error_maps_shapes_and_values():
    img = np.stack([X, X, X], axis=2)
    for metric in M.ERROR_MAPS:
        assert M.error_map(img, R, metric).shape == (2, 2)
    np.testing.assert_allclose(M.error_map(X, R, "mse"), [[0, 1], [0, 4]])
    np.testing.assert_allclose(M.error_map(X, R, "relmse"), [[0, 1 / 4.01], [0, 4 / 4.01]])
    np.testing.assert_allclose(M.error_map(X, R, "mape"), [[0, 1 / 2.01], [0, 2 / 2.01]])
    ref = np.zeros((2, 2, 3))
    e = M.error_map(np.array([[[3, 0, 0], [0, 0, 0]], [[0, 0, 0], [0, 0, 0]]]), ref, "mse")
    np.testing.assert_allclose(e, [[3, 0], [0, 0]])  # the mean of the three channels
    assert M.error_map(_smooth_image(40, 30), _smooth_image(40, 30) * 0.9, "flip").shape == (40, 30)
    with pytest.raises(InputError) as err:
        M.error_map(X, R, "ssim")
    assert str(err.value) == "unknown error map 'ssim' (allowed: mse, relmse, mape, flip, flip-hdr)"


def test_write_error_map(tmp_path):
    e = np.linspace(0, 2, 12).reshape(3, 4)
    e[0, 0] = np.nan
    p = str(tmp_path / "e.png")
    assert M.write_error_map(p, e, vmax=1.0) == (0.0, 1.0)
    assert open(p, "rb").read(8) == b"\x89PNG\r\n\x1a\n"
    rgb = M._decode_png(open(p, "rb").read())
    assert rgb.shape == (3, 4, 3)
    assert tuple(np.round(rgb[0, 0] * 255)) == M.NONFINITE_COLOUR
    np.testing.assert_array_equal(rgb[2, 3], rgb[2, 2])  # both above vmax: the brightest colour
    assert rgb[0, 1].sum() < rgb[1, 0].sum() < rgb[2, 3].sum()
    lo, hi = M.write_error_map(p, np.linspace(0, 1, 101).reshape(1, 101))
    assert lo == 0.0 and hi == pytest.approx(0.99)  # default range: up to the 99th percentile
    x = str(tmp_path / "e.exr")
    e2 = np.arange(6, dtype=np.float32).reshape(2, 3)
    assert M.write_error_map(x, e2) == (0.0, 5.0)
    back = caustica.read_image(x)
    assert back.shape == (2, 3, 3) and np.array_equal(back[..., 1], e2)
    for bad, msg in ((str(tmp_path / "e.jpg"), "unknown output format '.jpg' (allowed: .png, .exr, .pfm)"),
                     (str(tmp_path / "no" / "e.png"), "does not exist")):
        with pytest.raises(InputError) as err:
            M.write_error_map(bad, e)
        assert msg in str(err.value)
    assert sorted(os.listdir(tmp_path)) == ["e.exr", "e.png"]


# ---- reading


def _png(arr, depth, ctype, interlace=False):
    """A PNG by hand: filter 0 on every row, optionally Adam7-interlaced."""
    arr = np.asarray(arr)
    h, w = arr.shape[:2]
    dt = ">u2" if depth == 16 else "u1"
    if interlace:
        passes = ((0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2))
        subs = [arr[y0::dy, x0::dx] for x0, y0, dx, dy in passes]
    else:
        subs = [arr]
    raw = b"".join(b"\x00" + row.astype(dt).tobytes() for s in subs if s.size for row in s)
    chunk = lambda k, d: struct.pack(">I", len(d)) + k + d + struct.pack(">I", zlib.crc32(k + d) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, int(interlace)))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def test_read_exr_pfm_png(tmp_path):
    rng = np.random.default_rng(4)
    img = (rng.random((6, 9, 3)) * 1.2).astype(np.float32)
    for ext in ("exr", "pfm", "png"):
        caustica.write_image(str(tmp_path / f"a.{ext}"), img)
    for ext in ("exr", "pfm"):
        a = M.read(str(tmp_path / f"a.{ext}"))
        assert a.dtype == np.float32 and a.shape == (6, 9, 3) and np.array_equal(a, img)
    png = M.read(tmp_path / "a.png")  # PathLike too
    assert png.dtype == np.float32 and png.shape == (6, 9, 3)
    want = M.srgb_decode(np.round(255 * M.srgb_encode(img)) / 255)  # 8-bit sRGB, decoded to linear
    np.testing.assert_allclose(png, want, atol=1e-6)
    assert M.mse(tmp_path / "a.exr", str(tmp_path / "a.pfm")) == 0.0


def test_read_png_kinds(tmp_path):
    v16 = np.array([[[0, 1000, 65535], [30000, 2, 65535]], [[7, 7, 7], [65535, 0, 0]]], np.uint16)
    p = tmp_path / "a.png"
    p.write_bytes(_png(v16, 16, 2))
    np.testing.assert_allclose(M.read(p), M.srgb_decode(v16 / 65535.0), rtol=1e-6)
    v8 = np.arange(9 * 10 * 4, dtype=np.uint8).reshape(9, 10, 4)  # RGBA, interlaced
    p.write_bytes(_png(v8, 8, 6, interlace=True))
    np.testing.assert_allclose(M.read(p), M.srgb_decode(v8[..., :3] / 255.0), rtol=1e-6)
    g = np.array([[0, 255], [128, 64]], np.uint8)  # grey: the same value in R, G and B
    p.write_bytes(_png(g, 8, 0))
    np.testing.assert_allclose(M.read(p), M.srgb_decode(np.repeat(g[..., None] / 255.0, 3, axis=2)), rtol=1e-6)


def test_read_arrays_and_numpy_files(tmp_path):
    g = np.array([[0.5, 1.0], [2.0, 0.0]])
    a = M.read(g)
    assert a.dtype == np.float32 and a.shape == (2, 2, 3) and np.all(a[..., 0] == g) and np.all(a[..., 2] == g)
    rgba = np.arange(2 * 3 * 4, dtype=np.float64).reshape(2, 3, 4)
    assert np.array_equal(M.read(rgba), rgba[..., :3])
    assert np.array_equal(M.read([[1, 2], [3, 4]])[..., 1], [[1, 2], [3, 4]])  # integers as they are
    np.save(tmp_path / "a.npy", rgba)
    np.savez(tmp_path / "b.npz", image=g)
    assert np.array_equal(M.read(tmp_path / "a.npy"), rgba[..., :3])
    assert np.array_equal(M.read(tmp_path / "b.npz"), a)


def test_bad_input_messages(tmp_path):
    d = str(tmp_path)
    (tmp_path / "bad.png").write_bytes(b"not a png at all")
    (tmp_path / "two.npz").write_bytes(b"")
    np.savez(tmp_path / "two.npz", a=np.zeros((2, 2)), b=np.zeros((2, 2)))
    cases = [
        (lambda: M.read(f"{d}/nope.exr"), f"cannot read '{d}/nope.exr': no such file"),
        (lambda: M.read(f"{d}/nope.png"), f"cannot read '{d}/nope.png': no such file"),
        (lambda: M.read(f"{d}/a.jpg"),
         f"cannot read '{d}/a.jpg': unknown image format '.jpg' (allowed: .exr, .pfm, .png, .npy, .npz)"),
        (lambda: M.read(f"{d}/bad.png"), f"cannot read '{d}/bad.png': not a PNG file"),
        (lambda: M.read(f"{d}/two.npz"), f"cannot read '{d}/two.npz': expected one array in the .npz, found 2"),
        (lambda: M.read(np.zeros((2, 2, 2))),
         "array: expected an image of shape (H, W), (H, W, 3) or (H, W, 4), got (2, 2, 2)"),
        (lambda: M.read(np.zeros((0, 3))), "array: the image is empty, shape (0, 3, 3)"),
        (lambda: M.read(np.array([["a"]])), "array: expected an array of real numbers, got dtype <U1"),
        (lambda: M.read(3), "expected an image path or an array, got int"),
        (lambda: M.mse(np.zeros((48, 64, 3)), np.zeros((32, 32, 3))), "images differ in size: 64x48 vs 32x32"),
        (lambda: M.flip(np.zeros((48, 64)), np.zeros((32, 32))), "images differ in size: 64x48 vs 32x32"),
        (lambda: M.relmse(X, R, eps=0), "eps must be a positive number, got 0"),
        (lambda: M.evaluate(X, R, ("mse", "psnr")),
         "unknown metric 'psnr' (allowed: mse, rmse, relmse, mape, ssim, flip, flip-hdr)"),
    ]
    for f, msg in cases:
        with pytest.raises(InputError) as e:
            f()
        assert str(e.value) == msg
