"""WebP textures (scene/texture_io.cpp, libwebp): glTF's EXT_texture_webp (in place of a texture's `source`,
embedded, as a data URI or a file) and .webp image files in JSON scenes; lossless images decode to the PNG's
texels exactly, lossy ones approximately; bad WebP data and bad references are input errors."""
import io
import warnings

import numpy as np
import pytest

import caustica
from conftest import lamp_plate, srgb_to_linear
from test_gltf import FILL_FOV, TEXELS, Gltf, png_bytes, quadrant_centres, render

from PIL import Image


def webp_bytes(pixels, lossless=True):
    """A WebP image of an (h, w, 3) or (h, w, 4) uint8 array (Pillow's libwebp)."""
    pixels = np.asarray(pixels, np.uint8)
    buf = io.BytesIO()
    Image.fromarray(pixels, "RGBA" if pixels.shape[2] == 4 else "RGB").save(
        buf, format="WEBP", lossless=lossless, quality=100 if lossless else 80, exact=True)  # exact: keeps RGB at alpha 0
    return buf.getvalue()


def emission_quad(tmp_path, mode, webp, fallback=None):
    """test_gltf's emission quad (a 2x2 nearest-filtered emission texture filling the image) whose texture
    is the WebP image `webp` through EXT_texture_webp, with an optional PNG `source` fallback."""
    g = Gltf()
    add_image = g.image_embedded if mode == "glb" else g.image_data_uri
    wi = add_image(webp)
    g.doc["images"][wi]["mimeType"] = "image/webp"
    if mode == "file":
        (tmp_path / "texels.webp").write_bytes(webp)
        g.doc["images"][wi] = {"uri": "texels.webp"}
    tex = {"sampler": g.add("samplers", {"magFilter": 9728, "minFilter": 9728}),
           "extensions": {"EXT_texture_webp": {"source": wi}}}
    if fallback is not None:
        tex["source"] = g.image_data_uri(fallback)
    g.add("textures", tex)
    mat = g.add("materials", {"emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0},
                              "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}})
    g.scene([g.add("nodes", {"mesh": g.quad(mat)}), g.camera(3.0, FILL_FOV)])
    g.doc["extensionsUsed"] = ["EXT_texture_webp"]
    if fallback is None:
        g.doc["extensionsRequired"] = ["EXT_texture_webp"]
    return g.write(tmp_path / ("quad.glb" if mode == "glb" else "quad.gltf"), "glb" if mode == "glb" else "bin")


@pytest.mark.parametrize("mode", ["datauri", "glb", "file"])
def test_gltf_webp_texels_render_exactly(tmp_path, mode):
    """A required EXT_texture_webp texture (lossless, no fallback) is read, without a warning: each quadrant
    shows its texel (sRGB decoded) exactly, as test_gltf's PNG version does."""
    path = emission_quad(tmp_path, mode, webp_bytes(TEXELS))
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        out = render(path)
    assert not w, [str(x.message) for x in w]
    for (r, c), px in quadrant_centres(out).items():
        np.testing.assert_allclose(px, srgb_to_linear(TEXELS[r, c] / 255.0), rtol=1e-4, atol=1e-5)


def test_gltf_webp_is_preferred_to_the_fallback(tmp_path):
    """With a PNG `source` as well, the extension's WebP image is used (the PNG's texels are other colours)."""
    out = render(emission_quad(tmp_path, "datauri", webp_bytes(TEXELS), fallback=png_bytes(255 - TEXELS)))
    for (r, c), px in quadrant_centres(out).items():
        np.testing.assert_allclose(px, srgb_to_linear(TEXELS[r, c] / 255.0), rtol=1e-4, atol=1e-5)


def test_lossy_webp_decodes_close_to_the_original(tmp_path):
    """A lossy WebP (quality 80) of a smooth 32x32 gradient (its texels within 12/255 of the original, by
    Pillow's decoder) as a plate's reflectance: the rendered pixels within 8/255 of the PNG's, with the same
    seed (measured 4.1/255); the red and blue ramps run across each other, so a swapped channel order would
    be off by far more."""
    y, x = np.mgrid[0:32, 0:32]
    grad = np.stack([x * 8, y * 8, 255 - x * 4 - y * 4], axis=-1).astype(np.uint8)
    (tmp_path / "grad.webp").write_bytes(webp_bytes(grad, lossless=False))
    (tmp_path / "grad.png").write_bytes(png_bytes(grad))
    imgs = [render_texture(tmp_path, name) for name in ("grad.webp", "grad.png")]
    assert np.abs(imgs[0] - imgs[1]).max() < 8 / 255


def render_texture(tmp_path, name, spp=2):
    """A JSON scene whose plate's reflectance is the image file `name` (next to the scene), rendered with
    seed 1."""
    scene = caustica.load_dict(lamp_plate({"type": "diffuse", "reflectance": {"texture": name, "filter": "nearest"}}),
                               base_dir=tmp_path)
    return caustica.render(scene, spp=spp, seed=1)


@pytest.mark.parametrize("channels", [3, 4])
def test_json_webp_file_renders_as_the_png(tmp_path, channels):
    """A .webp image file (lossless, RGB and RGBA) in a JSON scene gives the same image, sample for sample, as
    the same texels in a PNG."""
    rng = np.random.default_rng(5)
    px = rng.integers(0, 256, size=(8, 8, channels), dtype=np.uint8)
    (tmp_path / "t.webp").write_bytes(webp_bytes(px))
    (tmp_path / "t.png").write_bytes(png_bytes(px))
    a, b = render_texture(tmp_path, "t.webp"), render_texture(tmp_path, "t.png")
    assert a.mean() > 0.01
    np.testing.assert_array_equal(a, b)


def test_bad_webp_is_an_input_error(tmp_path):
    """Corrupt WebP data names the image; an EXT_texture_webp source out of range names its JSON path."""
    path = emission_quad(tmp_path, "datauri", b"RIFF\x10\x00\x00\x00WEBPVP8 garbage!")
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(path)
    assert str(e.value) == (f"{path}: /images/0: cannot decode image '{path}#/images/0': not a valid WebP image")
    (tmp_path / "bad.webp").write_bytes(b"RIFF\x10\x00\x00\x00WEBPVP8 garbage!")
    with pytest.raises(caustica.InputError) as e:
        render_texture(tmp_path, "bad.webp")
    assert "bad.webp': not a valid WebP image" in str(e.value)
    g = Gltf()
    g.add("textures", {"extensions": {"EXT_texture_webp": {"source": 3}}})
    g.scene([])
    path = g.write(tmp_path / "range.gltf")
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(path)
    assert str(e.value) == f"{path}: /textures/0/extensions/EXT_texture_webp/source: index 3 out of range (/images is empty)"
