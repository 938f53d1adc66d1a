"""KHR_materials_clearcoat: a GGX coat of IOR 1.5 over the metallic-roughness material
(material/metallic_roughness.h), in JSON (`clearcoat`, `clearcoat_roughness`) and glTF. Every integrator sees
the same coat (its lobes sampled and evaluated in both transport directions), its textures scale it at the
hit, its normal is the surface's or its own normal map's (not the base's map), and a glTF coat exports to JSON
and renders the same. The BSDF itself (chi-square, weights, furnace,
reciprocity, the layer formula, the smooth coat's mirror mass) is tested in tests/cpp/test_bsdf.cpp."""
import json
import os
import sys
import warnings

import numpy as np
import pytest

import caustica
from conftest import lamp_plate, region_z, seeded_region_stats

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def validate(doc):
    import jsonschema  # installed by make deps, as the other schema tests assume
    with open(os.path.join(ROOT, "docs", "scene.schema.json")) as f:
        jsonschema.Draft202012Validator(json.load(f)).validate(doc)


def png_rgba(rgba):
    """A 4 x 4 PNG of one RGBA colour (0-255 each), as bytes: the one texture of gltf_with's layer tests."""
    from PIL import Image
    import io
    buf = io.BytesIO()
    Image.fromarray(np.full((4, 4, 4), rgba, np.uint8), "RGBA").save(buf, format="PNG")
    return buf.getvalue()


def gltf_with(tmp_path, extension, ext, base_color, roughness, image=None):
    """A glTF file of one quad (test_gltf's builder) whose material has `extension` = `ext`, optionally with
    a PNG image as texture 0."""
    sys.path.insert(0, os.path.dirname(__file__))
    from test_gltf import Gltf, FILL_FOV
    g = Gltf()
    if image is not None:
        g.image_data_uri(image)
        g.add("textures", {"source": 0})
    mat = g.add("materials", {"pbrMetallicRoughness": {"baseColorFactor": list(base_color) + [1.0],
                                                       "metallicFactor": 0.0, "roughnessFactor": roughness},
                              "extensions": {extension: ext}})
    g.doc["extensionsUsed"] = [extension]
    g.scene([g.add("nodes", {"mesh": g.quad(mat)}), g.camera(3.0, FILL_FOV)])
    return g.write(tmp_path / "layers.gltf")


def export_round_trip(tmp_path, path, extension):
    """Exports a glTF file to JSON: no warning names `extension` (it is supported), the export is valid
    against the schema and renders the glTF's image exactly. Returns the exported material."""
    out = tmp_path / "export.json"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        caustica.export_scene(path, str(out))
    assert not [w for w in caught if extension in str(w.message)], [str(w.message) for w in caught]
    doc = json.loads(out.read_text())
    validate(doc)
    a = caustica.render(caustica.load_scene(path, width=16, height=16), spp=4, seed=3)
    b = caustica.render(caustica.load_scene(str(out), width=16, height=16), spp=4, seed=3)
    assert np.isfinite(a).all() and a.max() > 0
    np.testing.assert_array_equal(a, b)
    (m,) = doc["materials"].values()
    return m


def plate_scene(coat=None, coat_roughness=0.0, texture=None):
    """A red rough plastic-like plate under a rectangular lamp, seen obliquely (the lamp's reflection lies in
    the image), with an optional clear coat (weight `coat`, or a texture scaled by it)."""
    mat = {"type": "metallic_roughness", "base_color": [0.6, 0.08, 0.05], "metallic": 0.0, "roughness": 0.6}
    if coat is not None:
        mat["clearcoat"] = coat if texture is None else {"texture": texture, "scale": coat, "filter": "nearest"}
        mat["clearcoat_roughness"] = coat_roughness
    return lamp_plate(mat, "paint")


SEEDS = range(1, 9)


@pytest.mark.parametrize("integrator", ["light", "bdpt", "vcm"])
def test_every_integrator_sees_the_rough_coat(integrator):
    """A rough coat (roughness 0.3) reflects the lamp in a glossy highlight: the light tracer, BDPT and VCM
    agree with the path tracer per 8x8 region (within 4.5 standard errors of the difference: two-sided
    p ~ 7e-6 per region), and the coat changes the image (the same comparison against the uncoated plate
    fails by far more)."""
    coated = caustica.load_dict(plate_scene(1.0, 0.3))
    ref = seeded_region_stats(coated, SEEDS, spp=32)
    got = seeded_region_stats(coated, SEEDS, integrator=integrator, spp=32)
    z = region_z(ref, got)
    assert z.max() < 4.5, z
    bare = seeded_region_stats(caustica.load_dict(plate_scene()), SEEDS, integrator=integrator, spp=32)
    assert region_z(got, bare).max() > 10.0


def test_bdpt_sees_the_smooth_coat():
    """A smooth coat (roughness 0, the default) is a mirror: the lamp's sharp reflection is reached only by
    the camera subpath; BDPT agrees with the path tracer per region, and the mirror makes the image
    brighter where the reflection lies."""
    coated = caustica.load_dict(plate_scene(1.0))
    ref = seeded_region_stats(coated, SEEDS, spp=32)
    got = seeded_region_stats(coated, SEEDS, integrator="bdpt", spp=32)
    z = region_z(ref, got)
    assert z.max() < 4.5, z
    bare = seeded_region_stats(caustica.load_dict(plate_scene()), SEEDS, spp=32)
    assert (region_z(ref, bare) > 10.0).any()


def test_coat_texture_scales_the_weight_at_the_hit(tmp_path):
    """A clearcoat texture's red channel times the weight: red 0 everywhere is no coat, red 1 the full
    weight (per region within 4.5 standard errors), whatever the other channels hold."""
    from PIL import Image
    for name, rgb in [("none.png", (0, 255, 255)), ("full.png", (255, 0, 0))]:
        Image.fromarray(np.full((4, 4, 3), rgb, np.uint8)).save(tmp_path / name)
    scene_file = tmp_path / "s.json"

    def stats(d):
        scene_file.write_text(json.dumps(d))
        return seeded_region_stats(caustica.load_scene(str(scene_file)), SEEDS, spp=16)

    coat, bare = stats(plate_scene(0.8, 0.2)), stats(plate_scene())
    none, full = stats(plate_scene(0.8, 0.2, "none.png")), stats(plate_scene(0.8, 0.2, "full.png"))
    assert region_z(none, bare).max() < 4.5
    assert region_z(full, coat).max() < 4.5
    assert region_z(full, none).max() > 10.0
    # The export keeps the textures (valid against the schema) and renders the same image.
    scene_file.write_text(json.dumps(plate_scene(0.8, 0.2, "full.png")))
    out = tmp_path / "out" / "x.json"
    out.parent.mkdir()
    caustica.export_scene(str(scene_file), str(out))
    doc = json.loads(out.read_text())
    validate(doc)
    m = doc["materials"]["paint"]
    assert m["clearcoat"]["scale"] == pytest.approx(0.8) and "texture" in m["clearcoat"]
    a = caustica.render(caustica.load_scene(str(scene_file)), spp=2, seed=5)
    b = caustica.render(caustica.load_scene(str(out)), spp=2, seed=5)
    np.testing.assert_array_equal(a, b)


def test_gltf_clearcoat_exports_and_renders_the_same(tmp_path):
    """A glTF material with KHR_materials_clearcoat (no "not supported" warning) exports to JSON with
    `clearcoat` and `clearcoat_roughness`, and the exported scene renders the glTF's image exactly."""
    path = gltf_with(tmp_path, "KHR_materials_clearcoat",
                     {"clearcoatFactor": 0.9, "clearcoatRoughnessFactor": 0.25}, (0.7, 0.1, 0.1), 0.5)
    m = export_round_trip(tmp_path, path, "KHR_materials_clearcoat")
    assert m["clearcoat"] == pytest.approx(0.9)
    assert m["clearcoat_roughness"] == pytest.approx(0.25)


# A constant tangent-space normal map tilting the normal by about 26 degrees towards +u and a little +v.
TILT_RGB = (166, 140, 242)


def coat_only_plate(tmp_path, normal_map=False, coat_normal_map=False, roughness=0.3):
    """lamp_plate of a coat (weight 1) over a black base without a specular layer, so that the coat alone
    reflects; `normal_map` gives the base the tilting map, `coat_normal_map` the coat."""
    from PIL import Image
    Image.fromarray(np.full((4, 4, 3), TILT_RGB, np.uint8)).save(tmp_path / "tilt.png")
    mat = {"type": "metallic_roughness", "base_color": 0.0, "metallic": 0.0, "roughness": 0.5, "specular": 0.0,
           "clearcoat": 1.0, "clearcoat_roughness": roughness}
    if normal_map:
        mat["normal_map"] = str(tmp_path / "tilt.png")
    if coat_normal_map:
        mat["clearcoat_normal_map"] = {"texture": str(tmp_path / "tilt.png"), "scale": 1.0}
    return lamp_plate(mat, "paint")


def test_coat_keeps_the_surface_normal_and_takes_its_own_map(tmp_path):
    """KHR_materials_clearcoat: the coat does not follow the base's normal map (a coat over a black base renders
    the same with and without one, per region within 4.5 standard errors) but follows its own
    `clearcoat_normal_map` (the tilt moves the highlight: more than 10 standard errors), whatever the base's map."""
    def stats(**kw):
        return seeded_region_stats(caustica.load_dict(coat_only_plate(tmp_path, **kw)), SEEDS, spp=16)

    flat, base_mapped = stats(), stats(normal_map=True)
    coat_mapped, both = stats(coat_normal_map=True), stats(normal_map=True, coat_normal_map=True)
    assert flat[0].max() > 0
    assert region_z(base_mapped, flat).max() < 4.5
    assert region_z(both, coat_mapped).max() < 4.5
    assert region_z(coat_mapped, flat).max() > 10.0


@pytest.mark.parametrize("integrator", ["light", "bdpt", "vcm"])
def test_every_integrator_sees_the_tilted_coat(tmp_path, integrator):
    """A coat tilted by its own normal map (over a red rough dielectric) makes the BSDF asymmetric: the light
    tracer, BDPT and VCM, which scatter light with its adjoint, agree with the path tracer per region (4.5
    standard errors of the difference)."""
    d = coat_only_plate(tmp_path, coat_normal_map=True)
    d["materials"]["paint"].update({"base_color": [0.6, 0.08, 0.05], "specular": 1.0})
    scene = caustica.load_dict(d)
    ref = seeded_region_stats(scene, SEEDS, spp=32)
    got = seeded_region_stats(scene, range(101, 109), integrator=integrator, spp=32)
    z = region_z(ref, got)
    assert z.max() < 4.5, z


def test_coat_normal_map_exports_from_gltf(tmp_path):
    """A glTF clearcoatNormalTexture (with its scale) exports as `clearcoat_normal_map` and renders the glTF's
    image exactly."""
    from PIL import Image
    import io
    buf = io.BytesIO()
    Image.fromarray(np.full((4, 4, 3), TILT_RGB, np.uint8)).save(buf, format="PNG")
    path = gltf_with(tmp_path, "KHR_materials_clearcoat",
                     {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.2,
                      "clearcoatNormalTexture": {"index": 0, "scale": 0.7}}, (0.7, 0.1, 0.1), 0.5, image=buf.getvalue())
    m = export_round_trip(tmp_path, path, "KHR_materials_clearcoat")
    assert m["clearcoat_normal_map"]["scale"] == pytest.approx(0.7)
    assert "texture" in m["clearcoat_normal_map"]


def test_bad_clearcoat_is_a_clear_error(tmp_path):
    d = plate_scene(1.0)
    d["materials"]["paint"]["clearcoat_roughness"] = 2
    with pytest.raises(caustica.SceneError, match=r"/materials/paint/clearcoat_roughness: expected a number in \[0, 1\]"):
        caustica.load_dict(d)
