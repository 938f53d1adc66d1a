"""KHR_materials_specular on the metallic-roughness material (material/metallic_roughness.h,
mr_dielectric_fresnel): JSON `specular` (weight) and `specular_color`, glTF specularFactor,
specularColorFactor and their textures. Weight 0 leaves the diffuse base alone (a Lambertian surface); a
tinted layer is seen alike by every integrator; a glTF file's layer exports to JSON and renders the same.
The BSDF itself (chi-square, weights, furnace, reciprocity, the mirror mass at normal and grazing
incidence) is tested in tests/cpp/test_bsdf.cpp."""
import json

import numpy as np
import pytest

import caustica
from test_clearcoat import SEEDS, export_round_trip, gltf_with, validate
from conftest import lamp_plate, region_z, seeded_region_stats


BASE = [0.3, 0.5, 0.2]


def mr(**extra):
    return dict({"type": "metallic_roughness", "base_color": BASE, "metallic": 0.0, "roughness": 0.15}, **extra)


def test_weight_zero_is_the_lambertian_base():
    """Without its specular layer the dielectric is its base, base/pi: the same image as a `diffuse` plate
    of that reflectance (per region within 4.5 standard errors); the default layer differs by far more."""
    spec0 = seeded_region_stats(caustica.load_dict(lamp_plate(mr(specular=0.0))), SEEDS, spp=16)
    lambert = seeded_region_stats(caustica.load_dict(lamp_plate({"type": "diffuse", "reflectance": BASE})), SEEDS,
                                  spp=16)
    plain = seeded_region_stats(caustica.load_dict(lamp_plate(mr())), SEEDS, spp=16)
    assert region_z(spec0, lambert).max() < 4.5
    assert region_z(plain, lambert).max() > 10.0


@pytest.mark.parametrize("integrator", ["light", "bdpt"])
def test_every_integrator_sees_the_tinted_layer(integrator):
    """A tinted, bright layer (colour (3, 1, 0.3), weight 0.8): the light tracer and BDPT agree with the path
    tracer per region, and the tint changes the image."""
    scene = caustica.load_dict(lamp_plate(mr(specular=0.8, specular_color=[3.0, 1.0, 0.3])))
    spp = 128 if integrator == "light" else 32  # the light tracer reaches the lamp's highlight less often
    ref = seeded_region_stats(scene, SEEDS, spp=32)
    got = seeded_region_stats(scene, SEEDS, integrator=integrator, spp=spp)
    assert region_z(ref, got).max() < 4.5, region_z(ref, got)
    plain = seeded_region_stats(caustica.load_dict(lamp_plate(mr())), SEEDS, integrator=integrator, spp=spp)
    assert region_z(got, plain).max() > 10.0


def test_gltf_specular_exports_and_renders_the_same(tmp_path):
    """A glTF material with KHR_materials_specular and both textures (no "not supported" warning) exports to
    JSON (valid against the schema) and the export renders the glTF's image exactly; the specularTexture's
    alpha channel survives the export's RGB images."""
    from PIL import Image
    import io
    rgba = np.zeros((4, 4, 4), np.uint8)
    rgba[..., 0], rgba[..., 1], rgba[..., 2] = 255, 128, 40
    rgba[:, :2, 3], rgba[:, 2:, 3] = 40, 255  # the weight: low on the left, full on the right
    buf = io.BytesIO()
    Image.fromarray(rgba, "RGBA").save(buf, format="PNG")
    ext = {"specularFactor": 0.9, "specularColorFactor": [1.5, 1.0, 1.0],
           "specularTexture": {"index": 0}, "specularColorTexture": {"index": 0}}
    path = gltf_with(tmp_path, "KHR_materials_specular", ext, (0.2, 0.3, 0.6), 0.3, buf.getvalue())
    m = export_round_trip(tmp_path, path, "KHR_materials_specular")
    assert m["specular"]["scale"] == pytest.approx(0.9) and "texture" in m["specular"]
    assert m["specular_color"]["scale"] == pytest.approx([1.5, 1.0, 1.0])


def test_bad_specular_is_a_clear_error():
    with pytest.raises(caustica.SceneError, match=r"/materials/plate/specular: expected a number in \[0, 1\]"):
        caustica.load_dict(lamp_plate(mr(specular=1.5)))
    with pytest.raises(caustica.SceneError, match=r"/materials/plate/specular_color"):
        caustica.load_dict(lamp_plate(mr(specular_color="")))


def test_transmission_texture_scales_the_weight_at_the_hit(tmp_path):
    """KHR_materials_transmission's transmissionTexture (JSON `transmission` as a texture): its red channel
    times the factor. A pane in front of a lamp: red 0 is the opaque material, red 1 the factor's glass (per
    region within 4.5 standard errors), and the two differ by far more; the export keeps the texture."""
    from PIL import Image
    for name, rgb in [("none.png", (0, 255, 255)), ("full.png", (255, 0, 0))]:
        Image.fromarray(np.full((4, 4, 3), rgb, np.uint8)).save(tmp_path / name)

    def pane(transmission):
        d = lamp_plate(mr(roughness=0.4, transmission=transmission))
        d["camera"] = {"position": [0, 0, 3], "target": [0, 0, 0], "fov": 40}
        d["shapes"][0]["transform"] = [{"scale": 0.8}]
        d["shapes"][1]["transform"] = [{"scale": 1.5}, {"look_at": {"origin": [0, 0, -1.5], "target": [0, 0, 0]}}]
        return d

    scene_file = tmp_path / "s.json"

    def stats(d):
        scene_file.write_text(json.dumps(d))
        return seeded_region_stats(caustica.load_scene(str(scene_file)), SEEDS, spp=16)

    opaque, glass = stats(pane(0.0)), stats(pane(0.7))
    none = stats(pane({"texture": "none.png", "scale": 0.7, "filter": "nearest"}))
    full = stats(pane({"texture": "full.png", "scale": 0.7, "filter": "nearest"}))
    assert region_z(none, opaque).max() < 4.5
    assert region_z(full, glass).max() < 4.5
    assert region_z(full, none).max() > 10.0
    out = tmp_path / "out" / "x.json"
    out.parent.mkdir()
    caustica.export_scene(str(scene_file), str(out))
    doc = json.loads(out.read_text())
    validate(doc)
    assert doc["materials"]["plate"]["transmission"]["scale"] == pytest.approx(0.7)
