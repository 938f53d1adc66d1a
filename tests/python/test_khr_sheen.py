"""KHR_materials_sheen on the metallic-roughness material (material/metallic_roughness.h): JSON `sheen_color`
and `sheen_roughness`, glTF sheenColorFactor, sheenRoughnessFactor and their textures. A black sheen is no
sheen; a sheen (a velvet's bright rim at grazing angles) is seen alike by every integrator; a glTF file's
sheen exports to JSON and renders the same. The BSDF itself (chi-square, weights, furnace including a smooth
sheen at grazing incidence, reciprocity, the albedo table, the layer formula) is tested in
tests/cpp/test_bsdf.cpp."""

import numpy as np
import pytest

import caustica
from test_clearcoat import SEEDS, TILT_RGB, export_round_trip, gltf_with, png_rgba
from conftest import lamp_plate, plate_cross_check, region_z, seeded_region_stats
from test_khr_specular import mr

CUDA, WHY = caustica.cuda_status()


def velvet(**extra):
    return mr(**dict(dict(roughness=0.7, sheen_color=[0.9, 0.6, 0.7], sheen_roughness=0.4), **extra))


def test_black_sheen_is_no_sheen_and_a_sheen_shows():
    """sheen_color 0 renders the plain material (per region within 4.5 standard errors); a sheen adds light
    (more than 10 standard errors somewhere)."""
    plain = seeded_region_stats(caustica.load_dict(lamp_plate(mr(roughness=0.7))), SEEDS, spp=16)
    black = seeded_region_stats(
        caustica.load_dict(lamp_plate(mr(roughness=0.7, sheen_color=0, sheen_roughness=0.4))), SEEDS, spp=16)
    sheen = seeded_region_stats(caustica.load_dict(lamp_plate(velvet())), SEEDS, spp=16)
    assert region_z(black, plain).max() < 4.5
    assert region_z(sheen, plain).max() > 10.0


@pytest.mark.parametrize("integrator", ["light", "bdpt", "vcm"])
def test_every_integrator_sees_the_sheen(integrator):
    """The light tracer, BDPT and VCM agree with the path tracer per region on a sheened plate under a clear
    coat (the sheen's lobe and its scaling of the layers under it are symmetric, so importance and radiance
    see the same surface)."""
    scene = caustica.load_dict(lamp_plate(velvet(clearcoat=0.5, clearcoat_roughness=0.2)))
    spp = 64 if integrator == "light" else 32
    ref = seeded_region_stats(scene, SEEDS, spp=32)
    got = seeded_region_stats(scene, SEEDS, integrator=integrator, spp=spp)
    assert region_z(ref, got).max() < 4.5, region_z(ref, got)


def test_a_sheen_roughness_texture_is_the_roughness_per_texel(tmp_path):
    """A sheen roughness texture times the factor is the roughness at the hit, for the lobe and for the albedo
    table that scales the layers under it: factor 1 times a grey texture of 51/255 renders as roughness 0.2
    (per region within 4.5 standard errors: z 0.09 measured; with the factor's table, as before 27d57cc, 208),
    and differs from roughness 1 (more than 10: 171)."""
    from PIL import Image
    import json
    Image.fromarray(np.full((4, 4, 3), 51, np.uint8)).save(tmp_path / "r.png")
    scene_file = tmp_path / "s.json"

    def stats(material):
        scene_file.write_text(json.dumps(lamp_plate(material)))
        return seeded_region_stats(caustica.load_scene(str(scene_file)), SEEDS, spp=16)

    textured = stats(mr(roughness=0.7, sheen_color=[0.9, 0.6, 0.7], sheen_roughness={"texture": "r.png"}))
    assert region_z(textured, stats(mr(roughness=0.7, sheen_color=[0.9, 0.6, 0.7], sheen_roughness=0.2))).max() < 4.5
    assert region_z(textured, stats(mr(roughness=0.7, sheen_color=[0.9, 0.6, 0.7], sheen_roughness=1.0))).max() > 10


def test_gltf_sheen_exports_and_renders_the_same(tmp_path):
    """A glTF material with KHR_materials_sheen and both textures (no "not supported" warning) exports to JSON
    (valid against the schema), and the export renders the glTF's image exactly."""
    ext = {"sheenColorFactor": [0.8, 0.7, 0.9], "sheenRoughnessFactor": 0.5,
           "sheenColorTexture": {"index": 0}, "sheenRoughnessTexture": {"index": 0}}
    path = gltf_with(tmp_path, "KHR_materials_sheen", ext, (0.2, 0.05, 0.1), 0.8, png_rgba((255, 200, 120, 90)))
    m = export_round_trip(tmp_path, path, "KHR_materials_sheen")
    assert m["sheen_color"]["scale"] == pytest.approx([0.8, 0.7, 0.9])
    assert m["sheen_roughness"]["scale"] == pytest.approx(0.5)


def test_bad_sheen_is_a_clear_error():
    with pytest.raises(caustica.SceneError, match=r"/materials/plate/sheen_color: expected colour values in \[0, 1\]"):
        caustica.load_dict(lamp_plate(mr(sheen_color=[2, 0, 0])))
    with pytest.raises(caustica.SceneError, match=r"/materials/plate/sheen_roughness: expected a number in \[0, 1\]"):
        caustica.load_dict(lamp_plate(mr(sheen_color=0.5, sheen_roughness=3)))


# Each a layered material and the same without its layer: the GPU test below requires the CPU and GPU to agree
# on the first and to differ from the second, so a layer the GPU dropped fails it.
def grey_texture(value):
    """A 4 x 4 PNG of one grey level (0-255), or of one RGB colour, in a temporary folder, by its absolute path
    (for load_dict)."""
    import os
    import tempfile
    from PIL import Image
    rgb = value if isinstance(value, tuple) else (value,) * 3
    path = os.path.join(tempfile.mkdtemp(prefix="caustica-sheen-"), "rgb%d_%d_%d.png" % rgb)
    Image.fromarray(np.full((4, 4, 3), rgb, np.uint8)).save(path)
    return path


GPU_LAYERS = {
    "coated-metal": (mr(metallic=1.0, roughness=0.4, clearcoat=0.8, clearcoat_roughness=0.1),
                     mr(metallic=1.0, roughness=0.4)),
    "coated-velvet": (velvet(clearcoat=0.5, clearcoat_roughness=0.3), mr(roughness=0.7)),
    "tinted-specular": (mr(specular=0.7, specular_color=[1.0, 0.6, 0.3]), mr()),
    # KHR_materials_iridescence's thin film over the metal and the dielectric (material/thin_film.h).
    "iridescent": (mr(metallic=0.5, roughness=0.3, iridescence=0.9, iridescence_thickness=350.0),
                   mr(metallic=0.5, roughness=0.3)),
    # A coat whose own normal map tilts it (Material::coat_normal, its adjoint in importance transport).
    "tilted-coat": (mr(metallic=1.0, roughness=0.4, clearcoat=0.8, clearcoat_roughness=0.1,
                       clearcoat_normal_map={"texture": "TILT"}),
                    mr(metallic=1.0, roughness=0.4, clearcoat=0.8, clearcoat_roughness=0.1)),
    # The sheen's albedo tables for a roughness texture (SceneView::sheen_table, uploaded to the GPU).
    "velvet-roughness-texture": (velvet(sheen_roughness={"texture": "GREY51"}), velvet(sheen_roughness=1.0)),
}


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
@pytest.mark.parametrize("integrator", ["path", "sppm", "vcm"])
@pytest.mark.parametrize("layers", GPU_LAYERS)
def test_cuda_renders_the_layers_as_the_cpu(integrator, layers):
    """The metallic-roughness layers on the GPU (the same CHD code as the CPU's, out of line behind mr_layered):
    each integrator on CUDA against the same integrator on the CPU on the lamp-lit plate, per region within 4.5
    standard errors over 16 seeds each, and more than 10 away from the plate without the layer. Measured with
    these seeds on the CPU, with device="cpu" and with the wavefront drivers (wavefront=True): 1.2-2.8 against
    the CPU, 35-132 against the plate without the layer; other sets of 16 seeds: at most 2.9 in 27 trials. The
    sheen roughness texture (its albedo tables, SceneView::sheen_table): 1.9 and 272 with path, device="cpu". The
    tilted coat (against the untilted one), device="cpu" and wavefront=True alike: 2.4-3.1 and 45-58."""
    material, variant = GPU_LAYERS[layers]
    if material.get("sheen_roughness") == {"texture": "GREY51"}:
        material = dict(material, sheen_roughness={"texture": grey_texture(51)})
    if material.get("clearcoat_normal_map") == {"texture": "TILT"}:
        material = dict(material, clearcoat_normal_map={"texture": grey_texture(TILT_RGB)})
    agree, differ = plate_cross_check(material, variant, integrator, reference=integrator, device="cuda")
    assert agree < 4.5, (integrator, layers, agree)
    assert differ > 10.0, (integrator, layers, differ)
