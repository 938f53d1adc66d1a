"""Cut-outs (scene/opacity.h): a material's opacity removes parts of a surface inside the ray queries, so every
integrator, its shadow rays and its photons see the same holes.

- A black screen of stochastic opacity a over a lit floor: a camera sees the floor through it with probability
  1 - a, and the floor gets the light through it with probability 1 - a, so the image is (1 - a)^2 times the
  unscreened floor, for every integrator (analytic; the spread over seeds gives the standard error).
- glTF alphaMode MASK cuts a texture's alpha out exactly, BLEND passes the factor's share, OPAQUE ignores alpha.
- The JSON scene format's `opacity` and `opacity_cutoff`, its errors, and the export round trip (an alpha
  channel goes out as a grey image)."""
import json
import math
import os

import numpy as np
import pytest

import caustica
import jsonschema
from test_gltf import Gltf, FILL_FOV, png_bytes

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

RES = 16
A = 0.4  # the screen's opacity


def screened_floor(opacity=A, cutoff=None):
    # Floor: diffuse albedo 0.5 at z = 0 under a directional light of irradiance pi straight down, so that its
    # radiance unscreened is 0.5. Screen: black, at z = 1, both larger than what the camera sees (a disc of
    # radius ~1.8 on the floor).
    screen = {"type": "diffuse", "reflectance": 0.0, "two_sided": True, "opacity": opacity}
    if cutoff is not None:
        screen["opacity_cutoff"] = cutoff
    return {
        "camera": {"position": [0, 0, 10], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 20,
                   "width": RES, "height": RES},
        "materials": {"floor": {"type": "diffuse", "reflectance": 0.5}, "screen": screen},
        "shapes": [{"type": "rectangle", "material": "floor", "transform": {"scale": 5}},
                   {"type": "rectangle", "material": "screen", "transform": {"scale": 5, "translate": [0, 0, 1]}}],
        "lights": [{"type": "directional", "direction": [0, 0, -1], "irradiance": math.pi}],
    }


def mean_over_seeds(scene, integrator, seeds, **opts):
    m = np.array([caustica.render(scene, integrator=integrator, seed=s, sampler="independent", **opts)[..., 1].mean()
                  for s in seeds])
    return m.mean(), m.std(ddof=1) / math.sqrt(len(m))


# Every integrator that renders surfaces, with sample counts that make the mean over six seeds of the analytic
# scenes here (and in test_blend.py) good to about 1%.
INTEGRATORS = [("path", dict(spp=16)), ("path", dict(spp=16, wavefront=True)), ("light", dict(spp=64)),
               ("bdpt", dict(spp=8)), ("vcm", dict(spp=8)), ("upg", dict(spp=8)),
               ("sppm", dict(spp=8, photons=20000)), ("pm", dict(spp=8, photons=20000)), ("restir", dict(spp=16))]
INTEGRATOR_IDS = ["path", "path-wavefront", "light", "bdpt", "vcm", "upg", "sppm", "pm", "restir"]


@pytest.mark.parametrize("integrator,opts", INTEGRATORS, ids=INTEGRATOR_IDS)
def test_a_screen_with_holes_passes_its_share_twice(integrator, opts):
    expected = (1 - A) ** 2 * 0.5  # 0.18; a screen that blocked only one way would give 0.3, an opaque one 0
    m, se = mean_over_seeds(screened_floor(), integrator, range(1, 7), **opts)
    assert se < 0.01, (integrator, se)
    # 4.5 standard errors of a mean of six (Student t with 5 degrees of freedom: p ~ 0.006).
    assert abs(m - expected) < 4.5 * se, (integrator, m, expected, se)


def test_an_alpha_test_makes_a_screen_all_or_nothing():
    # Opacity 0.4 under a cutoff of 0.5 is absent (the floor's full 0.5); under a cutoff of 0.3 it is solid.
    img = caustica.render(screened_floor(cutoff=0.5), spp=4, seed=1)
    assert img[..., 1].mean() == pytest.approx(0.5, rel=0.05)
    img = caustica.render(screened_floor(cutoff=0.3), spp=4, seed=1)
    assert img[..., 1].max() == 0.0


# Alpha per texel, top row first: the top-left and bottom-right texels are opaque (0.8 and 0.6), the others
# nearly clear (0.1 and 0.3).
ALPHA = np.array([[204, 26], [77, 153]], np.uint8)


def gltf_cutout(tmp_path, mode, base_alpha=1.0, cutoff=None, textured=True):
    """An emissive quad filling the image (emission 1 where it is), the base colour's alpha from a 2 x 2
    nearest texture (or none); nothing behind it."""
    g = Gltf()
    mat = {"emissiveFactor": [1, 1, 1], "alphaMode": mode,
           "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, base_alpha]}}
    if textured:
        rgba = np.zeros((2, 2, 4), np.uint8)
        rgba[..., 3] = ALPHA
        img = g.image_data_uri(png_bytes(rgba))
        g.add("samplers", {"magFilter": 9728, "minFilter": 9728})
        g.add("textures", {"source": img, "sampler": 0})
        mat["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    if cutoff is not None:
        mat["alphaCutoff"] = cutoff
    m = g.add("materials", mat)
    g.scene([g.add("nodes", {"mesh": g.quad(m)}), g.camera(3.0, FILL_FOV)])
    return g.write(tmp_path / ("cut_%s.gltf" % mode))


def quadrant_means(img):
    """The mean of the central 8 x 8 pixels of each quadrant (of a 32 x 32 image): away from the texel
    edges and the image border, which the pixel filter blurs."""
    g = img[..., 1]
    return np.array([[g[16 * r + 4:16 * r + 12, 16 * c + 4:16 * c + 12].mean() for c in (0, 1)] for r in (0, 1)])


def test_gltf_mask_blend_and_opaque(tmp_path):
    # MASK with the default cutoff 0.5: the texels of alpha 0.8 and 0.6 are there, 0.1 and 0.3 are not.
    s = caustica.load_scene(gltf_cutout(tmp_path, "MASK"), width=32, height=32)
    q = quadrant_means(caustica.render(s, spp=4, seed=1))
    np.testing.assert_array_equal(q, [[1.0, 0.0], [0.0, 1.0]])
    # alphaCutoff 0.2 keeps the 0.3 texel too; the factor multiplies the texture's alpha (0.5 x 0.6 < 0.5).
    s = caustica.load_scene(gltf_cutout(tmp_path, "MASK", cutoff=0.2), width=32, height=32)
    np.testing.assert_array_equal(quadrant_means(caustica.render(s, spp=4, seed=1)), [[1, 0], [1, 1]])
    s = caustica.load_scene(gltf_cutout(tmp_path, "MASK", base_alpha=0.5), width=32, height=32)
    np.testing.assert_array_equal(quadrant_means(caustica.render(s, spp=4, seed=1)), [[0, 0], [0, 0]])
    # BLEND: each texel's alpha is the share of camera rays that stop there (binomial, 128 spp x 64 pixels:
    # SE <= sqrt(0.25 / 8192) = 0.0055; 5 SE).
    s = caustica.load_scene(gltf_cutout(tmp_path, "BLEND"), width=32, height=32)
    q = quadrant_means(caustica.render(s, spp=128, seed=2, sampler="independent"))
    np.testing.assert_allclose(q, ALPHA / 255.0, atol=5 * 0.0055)
    # OPAQUE ignores alpha.
    s = caustica.load_scene(gltf_cutout(tmp_path, "OPAQUE"), width=32, height=32)
    np.testing.assert_array_equal(quadrant_means(caustica.render(s, spp=4, seed=1)), [[1, 1], [1, 1]])


def test_gltf_alpha_mode_errors(tmp_path):
    path = gltf_cutout(tmp_path, "CUTOUT", textured=False)
    with pytest.raises(caustica.SceneError, match=r"/materials/0/alphaMode: expected OPAQUE, MASK or BLEND"):
        caustica.load_scene(path)


def test_json_opacity_errors(tmp_path):
    def err(material):
        doc = screened_floor()
        doc["materials"]["screen"] = material
        p = tmp_path / "bad.json"
        p.write_text(json.dumps(doc))
        with pytest.raises(caustica.SceneError) as e:
            caustica.load_scene(str(p))
        return str(e.value)

    assert "/materials/screen/opacity: expected a number in [0, 1]" in err({"type": "diffuse", "opacity": 1.5})
    assert "/materials/screen/opacity_cutoff: needs \"opacity\"" in err({"type": "diffuse", "opacity_cutoff": 0.5})
    caustica.write_image(str(tmp_path / "m.exr"), np.ones((2, 2, 3), np.float32))
    assert "/materials/screen/opacity/channel: unknown channel 'red'" in err(
        {"type": "diffuse", "opacity": {"texture": "m.exr", "channel": "red"}})


def test_export_keeps_the_cutouts(tmp_path):
    # glTF MASK (the base colour texture's alpha) exported to JSON and read back renders the same image; the
    # alpha channel is written as a grey image read by its luminance.
    src = gltf_cutout(tmp_path, "MASK")
    out = tmp_path / "export.json"
    caustica.export_scene(src, str(out))
    doc = json.loads(out.read_text())
    jsonschema.Draft202012Validator(json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))).validate(doc)
    (mat,) = [m for m in doc["materials"].values() if "opacity" in m]
    assert mat["opacity"]["channel"] == "luminance"
    assert mat["opacity"]["texture"].endswith(".alpha.exr")
    assert mat["opacity_cutoff"] == 0.5
    a = caustica.render(caustica.load_scene(src, width=32, height=32), spp=4, seed=1)
    b = caustica.render(caustica.load_scene(str(out), width=32, height=32), spp=4, seed=1)
    np.testing.assert_array_equal(a, b)


def lamp_over_floor(opacity, emission):
    # A large emitting square facing down at z = 1 over a diffuse floor; the camera is between them (z = 0.9),
    # looking down, so that only light from the lamp reaches the image.
    return {
        "camera": {"position": [0, 0, 0.9], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 60,
                   "width": RES, "height": RES},
        "materials": {"floor": {"type": "diffuse", "reflectance": 0.5},
                      "lamp": {"type": "diffuse", "reflectance": 0.0, "opacity": opacity}},
        "shapes": [{"type": "rectangle", "material": "floor", "transform": {"scale": 5}},
                   {"type": "rectangle", "material": "lamp", "emission": emission, "flip_normals": True,
                    "transform": {"scale": 5, "translate": [0, 0, 1]}}],
    }


@pytest.mark.parametrize("integrator,opts", [
    ("path", dict(spp=16)),
    ("path", dict(spp=16, lanes=False)),
    ("bdpt", dict(spp=8)),
    ("light", dict(spp=512)),
    ("vcm", dict(spp=8)),
    ("sppm", dict(spp=16, photons=50000)),
], ids=["path", "path-scalar", "bdpt", "light", "vcm", "sppm"])
def test_an_emitter_with_holes_emits_its_share(integrator, opts):
    # A lamp of opacity 0.5 and emission 1 lights the floor as an opaque lamp of emission 0.5 does: rays that
    # reach it get through with probability 1/2, and its light samples carry that coverage (in the eight-lane
    # path tracer too, which leaves such lights to the scalar one). Each integrator against itself on the
    # opaque lamp (independent seeds), so that the photon mappers' kernel bias, the same in both, cancels.
    m, se = mean_over_seeds(lamp_over_floor(0.5, 1.0), integrator, range(1, 7), **opts)
    ref, ref_se = mean_over_seeds(lamp_over_floor(1.0, 0.5), integrator, range(101, 107), **opts)
    assert abs(m - ref) < 4.5 * math.hypot(se, ref_se), (integrator, m, ref, se, ref_se)
    # Ignoring the coverage in next-event estimation makes the path tracer 16% brighter here (measured: 32
    # standard errors); the tolerance stays well below that.
    assert 4.5 * math.hypot(se, ref_se) < 0.12 * ref
