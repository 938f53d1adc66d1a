"""KHR_materials_diffuse_transmission on the metallic-roughness material (material/metallic_roughness.h): JSON
`diffuse_transmission` and `diffuse_transmission_color`, glTF diffuseTransmissionFactor,
diffuseTransmissionColorFactor and their textures. A translucent sheet under a white sky has the closed-form
radiance (1 - dt) base + dt t at IOR 1, from either side and with textures; light through it is seen alike by
every integrator; a glTF file's diffuse transmission exports to JSON and renders the same. The BSDF itself
(chi-square, weights, furnace, reciprocity, the layer formula, the glass keeping its sides) is tested in
tests/cpp/test_bsdf.cpp, the glTF reading in tests/cpp/test_gltf_loader.cpp."""

import numpy as np
import pytest

import caustica
from conftest import plate_cross_check, white_sky_plate
from test_clearcoat import export_round_trip, gltf_with, png_rgba
from test_khr_sheen import grey_texture

CUDA, WHY = caustica.cuda_status()

BASE = [0.9, 0.6, 0.3]
TRANSMITTED = [0.3, 0.8, 0.5]


def leaf(**extra):
    """A rough dielectric metallic-roughness material that transmits 60% of its diffuse base."""
    return dict({"type": "metallic_roughness", "base_color": BASE, "metallic": 0.0, "roughness": 0.5,
                 "diffuse_transmission": 0.6, "diffuse_transmission_color": TRANSMITTED}, **extra)


def sky_radiance(material, behind=False, spp=64):
    """Mean radiance and its standard error per channel over the pixels of white_sky_plate(material): the plate
    seen head-on under a white sky of radiance 1 (from behind with `behind`)."""
    d = white_sky_plate(material)
    if behind:
        d["camera"]["position"] = [0, 0, -10]
    img = np.asarray(caustica.render(caustica.load_dict(d), spp=spp, seed=5), np.float64)[:, :, :3]
    px = img.reshape(-1, 3)
    return px.mean(axis=0), px.std(axis=0, ddof=1) / np.sqrt(len(px))


@pytest.mark.parametrize("behind", [False, True])
@pytest.mark.parametrize("dt", [0.25, 1.0])
def test_at_ior_one_a_sheet_under_a_white_sky_shows_its_two_colours(dt, behind):
    """At IOR 1 (no specular layer) a plate that reflects (1 - dt) of its base colour and transmits dt of its
    transmission colour, lit by a white sky of radiance 1 on both sides, shows (1 - dt) base + dt t, from the
    front and, since a translucent surface is the same from both sides (one-sided though it is), from behind:
    per channel within 4.5 standard errors (256 pixels of 64 samples each)."""
    mean, se = sky_radiance(leaf(eta=1.0, diffuse_transmission=dt), behind)
    want = (1 - dt) * np.array(BASE) + dt * np.array(TRANSMITTED)
    assert (np.abs(mean - want) < 4.5 * se + 1e-6).all(), (mean, want, se)


def test_textures_scale_the_weight_and_tint_the_colour():
    """The weight texture's red channel times the factor, and the colour texture (sRGB) times the colour: a grey
    texture of 128/255 (0.502 linear as data) with factor 1 and a colour texture of sRGB (255, 128, 64) over a
    white colour factor show (1 - w) base + w c at IOR 1, w = 128/255, c the texture's linear colour (4.5
    standard errors per channel)."""
    w = 128 / 255
    srgb = np.array([255, 128, 64]) / 255
    c = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    material = leaf(eta=1.0, diffuse_transmission={"texture": grey_texture(128), "filter": "nearest"},
                    diffuse_transmission_color={"texture": grey_texture((255, 128, 64)), "filter": "nearest"})
    mean, se = sky_radiance(material)
    want = (1 - w) * np.array(BASE) + w * c
    assert (np.abs(mean - want) < 4.5 * se + 1e-6).all(), (mean, want, se)


def test_difftrans_transmittance_takes_a_texture():
    """The `difftrans` material's transmittance may be a texture too (the same slot as the colour of
    KHR_materials_diffuse_transmission): with no reflectance, a plate under a white sky shows scale times the
    texture's linear value (sRGB 128 -> 0.2158), from the front, within 4.5 standard errors."""
    material = {"type": "difftrans", "reflectance": 0.0,
                "transmittance": {"texture": grey_texture(128), "scale": [0.8, 0.5, 1.0], "filter": "nearest"}}
    mean, se = sky_radiance(material)
    c = ((128 / 255 + 0.055) / 1.055) ** 2.4
    want = np.array([0.8, 0.5, 1.0]) * c
    assert (np.abs(mean - want) < 4.5 * se + 1e-6).all(), (mean, want, se)


@pytest.mark.parametrize("integrator", ["light", "bdpt", "vcm", "sppm"])
def test_every_integrator_sees_light_through_the_sheet(integrator):
    """The lamp-lit plate over a grey floor: light passes the plate, lights the floor and comes back through it.
    Each integrator that traces light agrees with the path tracer per region within 4.5 standard errors over 16
    seeds, and the image differs by more than 10 from the same plate without diffuse transmission. sppm's
    radius makes it biased: its reference is the path tracer on the same material all the same (the floor is
    lit smoothly, the bias is far below the noise at 32 pixels)."""
    material = leaf(clearcoat=0.4, clearcoat_roughness=0.2, sheen_color=[0.5, 0.4, 0.6], sheen_roughness=0.5)
    variant = dict(material, diffuse_transmission=0.0)
    agree, differ = plate_cross_check(material, variant, integrator, floor=True,
                                      spp=64 if integrator == "light" else 32)
    assert agree < 4.5, (integrator, agree)
    assert differ > 10.0, (integrator, differ)


def test_gltf_diffuse_transmission_exports_and_renders_the_same(tmp_path):
    """A glTF material with KHR_materials_diffuse_transmission and both textures (no "not supported" warning)
    exports to JSON (valid against the schema), and the export renders the glTF's image exactly."""
    ext = {"diffuseTransmissionFactor": 0.7, "diffuseTransmissionColorFactor": [0.9, 0.8, 0.5],
           "diffuseTransmissionTexture": {"index": 0}, "diffuseTransmissionColorTexture": {"index": 0}}
    path = gltf_with(tmp_path, "KHR_materials_diffuse_transmission", ext, (0.2, 0.5, 0.1), 0.6,
                     png_rgba((255, 200, 120, 90)))
    m = export_round_trip(tmp_path, path, "KHR_materials_diffuse_transmission")
    assert m["diffuse_transmission"]["scale"] == pytest.approx(0.7)
    assert m["diffuse_transmission_color"]["scale"] == pytest.approx([0.9, 0.8, 0.5])


def test_bad_diffuse_transmission_is_a_clear_error():
    from conftest import lamp_plate
    with pytest.raises(caustica.SceneError,
                       match=r"/materials/plate/diffuse_transmission: expected a number in \[0, 1\]"):
        caustica.load_dict(lamp_plate(leaf(diffuse_transmission=1.5)))
    with pytest.raises(caustica.SceneError,
                       match=r"/materials/plate/diffuse_transmission_color: expected colour values in \[0, 1\]"):
        caustica.load_dict(lamp_plate(leaf(diffuse_transmission_color=[2, 0, 0])))
    # A pair of sides must reflect only: a translucent side lets light through.
    d = lamp_plate({"type": "two_sided", "materials": ["front", "back"]})
    d["materials"].update(front=leaf(), back={"type": "diffuse"})
    with pytest.raises(caustica.SceneError, match="must reflect only"):
        caustica.load_dict(d)


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
@pytest.mark.parametrize("integrator", ["path", "sppm", "vcm"])
def test_cuda_renders_diffuse_transmission_as_the_cpu(integrator):
    """The translucent plate over the floor on the GPU against the same integrator on the CPU: per region within
    4.5 standard errors over 16 seeds each, and more than 10 from the plate without diffuse transmission."""
    material = leaf(clearcoat=0.4, clearcoat_roughness=0.2)
    agree, differ = plate_cross_check(material, dict(material, diffuse_transmission=0.0), integrator,
                                      reference=integrator, device="cuda", floor=True)
    assert agree < 4.5, (integrator, agree)
    assert differ > 10.0, (integrator, differ)
