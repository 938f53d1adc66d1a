"""Image metrics: how far a rendered image is from a reference (docs/metrics.md).

    import caustica.metrics as m
    m.relmse("render.exr", "reference.exr")          # mean of (x - r)^2 / (r^2 + 0.01)
    m.flip(image, reference)                         # LDR-FLIP of the sRGB display images
    m.flip(image, reference, mode="hdr")             # HDR-FLIP of the linear images
    m.evaluate(image, reference)                     # {"mse": ..., "rmse": ..., ..., "flip": ...}
    m.write_error_map("err.png", m.error_map(image, reference, "flip"))

Every function takes paths (.exr, .pfm, .png, .npy, .npz) or arrays ((H, W), (H, W, 3) or (H, W, 4));
`read` turns either into float32 (H, W, 3) linear RGB. The second argument is always the reference.
Metrics return Python floats. Bad input raises caustica.InputError with one line saying what is wrong.
"""
from __future__ import annotations

import math
import os
import struct
import zlib
from typing import Iterable, Optional, Union

import numpy as np

from ._api import InputError, read_image, write_image

__all__ = ["METRICS", "DEFAULT_METRICS", "ERROR_MAPS", "EPS", "read", "mse", "rmse", "relmse", "mape",
           "ssim", "flip", "error_map", "write_error_map", "evaluate", "tonemap", "srgb_encode",
           "srgb_decode"]

METRICS = ("mse", "rmse", "relmse", "mape", "ssim", "flip", "flip-hdr")
DEFAULT_METRICS = ("mse", "rmse", "relmse", "mape", "ssim", "flip")
ERROR_MAPS = ("mse", "relmse", "mape", "flip", "flip-hdr")
EPS = 0.01  # relMSE and MAPE: the project's epsilon (shared/scenes/cornell-box.md)
READ_FORMATS = (".exr", ".pfm", ".png", ".npy", ".npz")

Image = Union[str, os.PathLike, np.ndarray]


# ---------------------------------------------------------------------------------------------
# Reading


def read(x: Image) -> np.ndarray:
    """A path (.exr, .pfm, .png, .npy, .npz) or an array -> float32 (H, W, 3) linear RGB.

    EXR and PFM are linear. PNG is taken as sRGB-encoded (8 or 16 bits; gAMA and iCCP chunks are
    ignored) and decoded to linear. Arrays (and .npy, or an .npz holding one array) are linear
    values taken as they are (an integer array is not rescaled): (H, W) is grey, (H, W, 3) RGB,
    (H, W, 4) RGBA whose alpha is dropped."""
    if isinstance(x, (str, os.PathLike)):
        return _read_path(os.fspath(x))
    if isinstance(x, np.ndarray) or isinstance(x, (list, tuple)):
        return _from_array(x, "array")
    raise InputError(f"expected an image path or an array, got {type(x).__name__}")


def _read_path(p: str) -> np.ndarray:
    ext = os.path.splitext(p)[1].lower()
    if ext not in READ_FORMATS:
        raise InputError(f"cannot read '{p}': unknown image format '{ext or '(none)'}' "
                         f"(allowed: {', '.join(READ_FORMATS)})")
    if os.path.isdir(p):
        raise InputError(f"cannot read '{p}': it is a directory")
    if not os.path.exists(p):
        raise InputError(f"cannot read '{p}': no such file")
    if ext in (".exr", ".pfm"):
        return np.ascontiguousarray(read_image(p), dtype=np.float32)
    if ext == ".png":
        with open(p, "rb") as f:
            data = f.read()
        try:
            return srgb_decode(_decode_png(data)).astype(np.float32)
        except InputError as e:
            raise InputError(f"cannot read '{p}': {e}") from None
    try:
        a = np.load(p, allow_pickle=False)
    except Exception as e:  # corrupt or pickled content
        raise InputError(f"cannot read '{p}': not a NumPy file ({e})") from None
    if isinstance(a, np.lib.npyio.NpzFile):
        with a:
            names = list(a.files)
            if len(names) != 1:
                raise InputError(f"cannot read '{p}': expected one array in the .npz, found {len(names)}")
            a = a[names[0]]
    return _from_array(a, f"'{p}'")


def _from_array(a, what: str) -> np.ndarray:
    try:
        a = np.asarray(a)
    except Exception:
        raise InputError(f"{what}: not an array of numbers") from None
    if a.dtype == bool or not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)):
        raise InputError(f"{what}: expected an array of real numbers, got dtype {a.dtype}")
    if a.ndim == 2:
        a = np.repeat(a[:, :, None], 3, axis=2)
    elif a.ndim == 3 and a.shape[2] == 1:
        a = np.repeat(a, 3, axis=2)
    elif a.ndim == 3 and a.shape[2] in (3, 4):
        a = a[:, :, :3]
    else:
        raise InputError(f"{what}: expected an image of shape (H, W), (H, W, 3) or (H, W, 4), got {a.shape}")
    if a.shape[0] == 0 or a.shape[1] == 0:
        raise InputError(f"{what}: the image is empty, shape {a.shape}")
    return np.ascontiguousarray(a, dtype=np.float32)


def _decode_png(data: bytes) -> np.ndarray:
    """PNG bytes -> float64 (H, W, 3) sRGB-encoded values in [0, 1] (alpha dropped)."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise InputError("not a PNG file")
    pos, ihdr, plte, idat = 8, None, None, []
    while pos + 8 <= len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if len(body) != n:
            raise InputError("truncated PNG file")
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"PLTE":
            plte = np.frombuffer(body, np.uint8).reshape(-1, 3)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + n
    if ihdr is None or not idat:
        raise InputError("truncated PNG file")
    w, h, depth, ctype, _, _, interlace = ihdr
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}.get(ctype)
    if channels is None or depth not in (1, 2, 4, 8, 16) or w == 0 or h == 0:
        raise InputError(f"unsupported PNG (colour type {ctype}, bit depth {depth})")
    if ctype == 3 and plte is None:
        raise InputError("palette PNG without a palette")
    try:
        raw = zlib.decompress(b"".join(idat))
    except zlib.error:
        raise InputError("corrupt PNG data") from None
    bits = channels * depth
    bpp = max(1, bits // 8)
    out = np.zeros((h, w, channels), np.uint16)
    if interlace:  # Adam7: seven sub-images, each filtered on its own
        passes = ((0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2))
    else:
        passes = ((0, 0, 1, 1),)
    pos = 0
    for x0, y0, dx, dy in passes:
        pw, ph = (w - x0 + dx - 1) // dx, (h - y0 + dy - 1) // dy
        if pw <= 0 or ph <= 0:
            continue
        stride = (pw * bits + 7) // 8
        size = ph * (stride + 1)
        if pos + size > len(raw):
            raise InputError("truncated PNG data")
        rows = _unfilter(raw[pos:pos + size], ph, stride, bpp)
        pos += size
        out[y0::dy, x0::dx] = _samples(rows, pw, channels, depth)
    if ctype == 3:
        idx = out[..., 0]
        if idx.max() >= len(plte):
            raise InputError("palette index out of range")
        return plte[idx].astype(np.float64) / 255.0
    v = out.astype(np.float64) / float((1 << depth) - 1)
    if channels <= 2:  # grey, grey + alpha
        return np.repeat(v[:, :, :1], 3, axis=2)
    return v[:, :, :3]


def _unfilter(buf: bytes, h: int, stride: int, bpp: int) -> np.ndarray:
    """Undoes the per-row PNG filters (None, Sub, Up, Average, Paeth) -> uint8 (h, stride)."""
    a = np.frombuffer(buf, np.uint8).reshape(h, stride + 1)
    kinds, rows = a[:, 0], a[:, 1:].copy()
    prev = np.zeros(stride, np.uint8)
    for y in range(h):
        k, r = kinds[y], rows[y]
        if k == 1:  # Sub: running sum per byte position modulo bpp
            for j in range(bpp):
                r[j::bpp] = np.cumsum(r[j::bpp], dtype=np.uint64).astype(np.uint8)
        elif k == 2:
            r += prev
        elif k in (3, 4):
            cur, up = bytearray(r.tobytes()), prev.tobytes()
            for i in range(stride):
                left = cur[i - bpp] if i >= bpp else 0
                if k == 3:
                    cur[i] = (cur[i] + ((left + up[i]) >> 1)) & 255
                else:
                    ul = up[i - bpp] if i >= bpp else 0
                    p = left + up[i] - ul
                    pa, pb, pc = abs(p - left), abs(p - up[i]), abs(p - ul)
                    pred = left if pa <= pb and pa <= pc else (up[i] if pb <= pc else ul)
                    cur[i] = (cur[i] + pred) & 255
            r[:] = np.frombuffer(bytes(cur), np.uint8)
        elif k != 0:
            raise InputError(f"corrupt PNG data (filter type {k})")
        prev = r
    return rows


def _samples(rows: np.ndarray, w: int, channels: int, depth: int) -> np.ndarray:
    h = rows.shape[0]
    if depth == 16:
        return rows.view(">u2").reshape(h, -1)[:, :w * channels].reshape(h, w, channels).astype(np.uint16)
    if depth == 8:
        return rows[:, :w * channels].reshape(h, w, channels).astype(np.uint16)
    bits = np.unpackbits(rows, axis=1)[:, :w * depth].reshape(h, w, depth)
    weights = (1 << np.arange(depth - 1, -1, -1)).astype(np.uint16)
    return (bits.astype(np.uint16) * weights).sum(axis=2, dtype=np.uint16)[:, :, None]


# ---------------------------------------------------------------------------------------------
# Display transform


def srgb_encode(v: np.ndarray) -> np.ndarray:
    """Linear [0, 1] -> sRGB-encoded [0, 1] (IEC 61966-2-1); values outside [0, 1] and NaN clamp."""
    v = np.asarray(v, dtype=np.float64)
    v = np.where(v > 0, np.minimum(v, 1.0), 0.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def srgb_decode(v: np.ndarray) -> np.ndarray:
    """sRGB-encoded [0, 1] -> linear [0, 1]."""
    v = np.asarray(v, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))


def tonemap(img: Image, exposure: float = 0.0) -> np.ndarray:
    """The image as `caustica render -o x.png` shows it: 2^exposure * x clamped to [0, 1]
    (NaN -> 0), then sRGB-encoded. float64 (H, W, 3) in [0, 1]."""
    return srgb_encode(read(img).astype(np.float64) * 2.0 ** float(exposure))


# ---------------------------------------------------------------------------------------------
# Metrics


def _pair(img: Image, ref: Image):
    a, r = read(img), read(ref)
    if a.shape != r.shape:
        raise InputError(f"images differ in size: {a.shape[1]}x{a.shape[0]} vs {r.shape[1]}x{r.shape[0]}")
    return a.astype(np.float64), r.astype(np.float64)


def _eps(eps) -> float:
    if isinstance(eps, bool) or not isinstance(eps, (int, float, np.floating, np.integer)) or not eps > 0 \
            or not math.isfinite(eps):
        raise InputError(f"eps must be a positive number, got {eps!r}")
    return float(eps)


def mse(img: Image, ref: Image) -> float:
    """Mean over pixels and channels of (x - r)^2."""
    a, r = _pair(img, ref)
    return float(np.mean((a - r) ** 2))


def rmse(img: Image, ref: Image) -> float:
    """sqrt(mse)."""
    return math.sqrt(mse(img, ref))


def relmse(img: Image, ref: Image, eps: float = EPS) -> float:
    """Mean over pixels and channels of (x - r)^2 / (r^2 + eps), eps = 0.01 by default."""
    eps = _eps(eps)
    a, r = _pair(img, ref)
    return float(np.mean((a - r) ** 2 / (r ** 2 + eps)))


def mape(img: Image, ref: Image, eps: float = EPS) -> float:
    """Mean over pixels and channels of |x - r| / (|r| + eps), eps = 0.01 by default."""
    eps = _eps(eps)
    a, r = _pair(img, ref)
    return float(np.mean(np.abs(a - r) / (np.abs(r) + eps)))


SSIM_WINDOW, SSIM_SIGMA, SSIM_K1, SSIM_K2 = 11, 1.5, 0.01, 0.03
LUMA = (0.2126, 0.7152, 0.0722)  # Rec. 709 / sRGB weights


def _gauss_taps(n: int) -> np.ndarray:
    x = np.arange(n, dtype=np.float64) - (n - 1) / 2.0
    g = np.exp(-x * x / (2.0 * SSIM_SIGMA ** 2))
    return g / g.sum()


def _filter_valid(img: np.ndarray, ty: np.ndarray, tx: np.ndarray) -> np.ndarray:
    """Separable correlation with taps ty (rows) and tx (columns), 'valid' region only."""
    h, w = img.shape
    ny, nx = len(ty), len(tx)
    rows = sum(tx[k] * img[:, k:k + w - nx + 1] for k in range(nx))
    return sum(ty[k] * rows[k:k + h - ny + 1, :] for k in range(ny))


def _luma(img: Image, exposure: float) -> np.ndarray:
    return np.tensordot(tonemap(img, exposure), np.array(LUMA), axes=([2], [0]))


def ssim_map(img: Image, ref: Image, exposure: float = 0.0) -> np.ndarray:
    """The local SSIM values of `ssim`, one per window position ('valid' region: (H - 10, W - 10)
    for images of at least 11x11 pixels)."""
    a, r = _pair(img, ref)
    x, y = _luma(a, exposure), _luma(r, exposure)
    ty = _gauss_taps(min(SSIM_WINDOW, x.shape[0]))
    tx = _gauss_taps(min(SSIM_WINDOW, x.shape[1]))
    f = lambda v: _filter_valid(v, ty, tx)
    c1, c2 = (SSIM_K1 * 1.0) ** 2, (SSIM_K2 * 1.0) ** 2
    mx, my = f(x), f(y)
    sxx, syy, sxy = f(x * x) - mx * mx, f(y * y) - my * my, f(x * y) - mx * my
    return ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))


def ssim(img: Image, ref: Image, exposure: float = 0.0) -> float:
    """Mean SSIM (Wang et al. 2004) of the luma of the display images (docs/metrics.md).

    Both images are tonemapped as `caustica render -o x.png` shows them (2^exposure * x clamped to
    [0, 1], sRGB-encoded); Y' = 0.2126 R' + 0.7152 G' + 0.0722 B'. Local statistics use an 11x11
    Gaussian window (sigma 1.5, normalised), over window positions wholly inside the image;
    C1 = (0.01 L)^2, C2 = (0.03 L)^2 with data range L = 1. An image narrower or lower than 11
    pixels uses the Gaussian sampled over its width or height (same sigma, renormalised)."""
    return float(np.mean(ssim_map(img, ref, exposure)))


FLIP_MODES = ("ldr", "hdr")


def _flip_module():
    try:
        import flip_evaluator
    except ImportError:
        raise InputError("FLIP needs the flip-evaluator package (pip install flip-evaluator==1.7)") from None
    return flip_evaluator


def _flip(img: Image, ref: Image, mode: str, exposure: float, need_map: bool):
    if not isinstance(mode, str) or mode.lower() not in FLIP_MODES:
        raise InputError(f"unknown FLIP mode {mode!r} (allowed: ldr, hdr)")
    mode = mode.lower()
    a, r = _pair(img, ref)
    fe = _flip_module()
    if mode == "ldr":
        # FLIP's LDR inputs are sRGB-encoded values in [0, 1]: the display images.
        ta = np.ascontiguousarray(tonemap(a, exposure), dtype=np.float32)
        tr = np.ascontiguousarray(tonemap(r, exposure), dtype=np.float32)
        emap, mean, _ = fe.evaluate(tr, ta, "LDR", inputsRGB=True, applyMagma=False, computeMeanError=True)
    else:
        # FLIP's HDR inputs are non-negative linear values; NaN, infinities and negatives become 0.
        clean = lambda v: np.ascontiguousarray(
            np.where(np.isfinite(v) & (v > 0), v, 0.0) * 2.0 ** float(exposure), dtype=np.float32)
        ta, tr = clean(a), clean(r)
        params = {}
        lum = lambda v: v @ np.array(LUMA, dtype=np.float32)
        if not (lum(tr) > 0).any():
            # FLIP derives its exposure range from the reference's luminance and cannot from a black one.
            if not (lum(ta) > 0).any():
                z = np.zeros(a.shape[:2], np.float64)
                return (z if need_map else None), 0.0
            _, _, p = fe.evaluate(ta, ta, "HDR", applyMagma=False, computeMeanError=False)
            params = {k: p[k] for k in ("startExposure", "stopExposure", "numExposures")}
        emap, mean, _ = fe.evaluate(tr, ta, "HDR", applyMagma=False, computeMeanError=True, parameters=params)
    emap = np.asarray(emap, dtype=np.float64).reshape(a.shape[:2])
    return emap, float(np.mean(emap))


def flip(img: Image, ref: Image, mode: str = "ldr", exposure: float = 0.0) -> float:
    """Mean FLIP error in [0, 1] (Andersson et al. 2020; flip-evaluator 1.7, 67 pixels per degree).

    mode "ldr": LDR-FLIP of the display images (2^exposure * x clamped to [0, 1], sRGB-encoded,
    as `caustica render -o x.png` writes them). mode "hdr": HDR-FLIP (Andersson et al. 2021) of the
    linear images scaled by 2^exposure, with FLIP's ACES tonemapper and its automatic exposure range
    from the reference (from the test image when the reference is all black)."""
    return _flip(img, ref, mode, exposure, need_map=False)[1]


def error_map(img: Image, ref: Image, metric: str = "relmse", eps: float = EPS,
              exposure: float = 0.0) -> np.ndarray:
    """Per-pixel error, float64 (H, W): "mse", "relmse", "mape" averaged over the three channels;
    "flip" (LDR) and "flip-hdr" are FLIP's own per-pixel maps (mean of the map = `flip`)."""
    if metric not in ERROR_MAPS:
        raise InputError(f"unknown error map '{metric}' (allowed: {', '.join(ERROR_MAPS)})")
    if metric in ("flip", "flip-hdr"):
        return _flip(img, ref, "ldr" if metric == "flip" else "hdr", exposure, need_map=True)[0]
    eps = _eps(eps)
    a, r = _pair(img, ref)
    d = a - r
    if metric == "mse":
        e = d * d
    elif metric == "relmse":
        e = d * d / (r * r + eps)
    else:
        e = np.abs(d) / (np.abs(r) + eps)
    return e.mean(axis=2)


ERROR_MAP_FORMATS = (".png", ".exr", ".pfm")
NONFINITE_COLOUR = (0, 255, 0)


def _check_write(path: str) -> str:
    ext = os.path.splitext(path)[1].lower()
    if ext not in ERROR_MAP_FORMATS:
        raise InputError(f"cannot write '{path}': unknown output format '{ext or '(none)'}' "
                         f"(allowed: {', '.join(ERROR_MAP_FORMATS)})")
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        raise InputError(f"cannot write '{path}': directory '{d}' does not exist")
    if os.path.isdir(path):
        raise InputError(f"cannot write '{path}': it is a directory")
    return ext


def write_error_map(path: Union[str, os.PathLike], emap: np.ndarray, vmin: float = 0.0,
                    vmax: Optional[float] = None, cmap: str = "magma") -> tuple:
    """Writes a per-pixel error map (H, W).

    .png: false colour (matplotlib's colour map `cmap`, magma by default), vmin -> darkest,
    vmax -> brightest, values outside clamped, non-finite pixels green; vmax defaults to the 99th
    percentile of the finite values (1 if there are none, or vmin + 1 if it is not above vmin).
    .exr / .pfm: the raw values in all three channels. Returns the (vmin, vmax) used (for .exr/.pfm,
    the finite minimum and maximum)."""
    p = os.fspath(path)
    ext = _check_write(p)
    e = np.asarray(emap, dtype=np.float64)
    if e.ndim != 2 or e.size == 0:
        raise InputError(f"write_error_map: expected an (H, W) array, got shape {e.shape}")
    finite = np.isfinite(e)
    if ext in (".exr", ".pfm"):
        write_image(p, np.repeat(e[:, :, None], 3, axis=2).astype(np.float32))
        vals = e[finite]
        return (float(vals.min()), float(vals.max())) if vals.size else (0.0, 0.0)
    if vmax is None:
        vmax = float(np.percentile(e[finite], 99)) if finite.any() else 1.0
        if not vmax > vmin:
            vmax = vmin + 1.0
    if not (math.isfinite(vmin) and math.isfinite(vmax) and vmax > vmin):
        raise InputError(f"write_error_map: expected vmin < vmax, got {vmin} and {vmax}")
    try:
        import matplotlib
        colours = matplotlib.colormaps[cmap]
    except ImportError:
        raise InputError("a false-colour PNG needs matplotlib (pip install matplotlib); write .exr instead") from None
    except KeyError:
        raise InputError(f"unknown colour map '{cmap}'") from None
    t = np.clip((np.where(finite, e, vmin) - vmin) / (vmax - vmin), 0.0, 1.0)
    rgb = np.round(colours(t)[:, :, :3] * 255.0).astype(np.uint8)
    rgb[~finite] = NONFINITE_COLOUR
    _write_png8(p, rgb)
    return float(vmin), float(vmax)


def _write_png8(path: str, rgb: np.ndarray) -> None:
    """8-bit RGB PNG, written to a temporary file and renamed into place."""
    h, w, _ = rgb.shape
    raw = np.concatenate([np.zeros((h, 1), np.uint8), rgb.reshape(h, w * 3)], axis=1).tobytes()
    chunk = lambda kind, body: (struct.pack(">I", len(body)) + kind + body
                                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))
    data = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"sRGB", b"\x00") + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
    tmp = f"{path}.tmp{os.getpid()}"
    try:
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except OSError as e:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise InputError(f"cannot write '{path}': {e.strerror}") from None


def _check_metrics(metrics: Iterable[str]) -> tuple:
    if isinstance(metrics, str):
        metrics = (metrics,)
    names = tuple(metrics)
    if not names:
        raise InputError(f"no metrics given (allowed: {', '.join(METRICS)})")
    for n in names:
        if n not in METRICS:
            raise InputError(f"unknown metric '{n}' (allowed: {', '.join(METRICS)})")
    return names


def evaluate(img: Image, ref: Image, metrics: Iterable[str] = DEFAULT_METRICS, exposure: float = 0.0) -> dict:
    """{name: value} for each of `metrics` (names from METRICS), in the order given. Each image is
    read once. exposure applies to the tonemapped metrics (ssim, flip) and flip-hdr."""
    names = _check_metrics(metrics)
    a, r = _pair(img, ref)
    out = {}
    for n in names:
        if n == "mse":
            out[n] = mse(a, r)
        elif n == "rmse":
            out[n] = rmse(a, r)
        elif n == "relmse":
            out[n] = relmse(a, r)
        elif n == "mape":
            out[n] = mape(a, r)
        elif n == "ssim":
            out[n] = ssim(a, r, exposure)
        elif n == "flip":
            out[n] = flip(a, r, "ldr", exposure)
        else:
            out[n] = flip(a, r, "hdr", exposure)
    return out
