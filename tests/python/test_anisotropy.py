"""Anisotropic roughness ([alpha_x, alpha_y] in JSON, alpha_u/alpha_v in Mitsuba XML) is measured along
the surface's dp/du (pbrt-v4's uroughness, Mitsuba 3's alpha_u; scene/shading.h, shading_tangent): a
rough conductor plate whose parameterisation is turned a quarter about its normal, with the two alphas
swapped, is the same surface, and every integrator that shades it (through its own shading frame: path,
the light tracer's and BDPT's light vertices, SPPM's visible points) sees the same highlight;
`anisotropy_rotation` (glTF KHR_materials_anisotropy's anisotropyRotation) turns the direction towards
dp/dv."""
import json
import math
import os
import warnings

import numpy as np
import pytest

import caustica
from conftest import region_z, seeded_region_stats

RES = 32


def plate_scene(alphas, turned):
    """A rough gold-like plate under a rectangular lamp, seen obliquely: the highlight is stretched along
    the plate's rougher direction. `turned`: the plate's UVs turned a quarter about its normal (the same
    square, dp/du along world z instead of world x)."""
    steps = [{"scale": 1.5}]
    if turned:
        steps.append({"rotate": {"axis": [0, 0, 1], "angle": 90}})
    steps.append({"rotate": {"axis": [1, 0, 0], "angle": -90}})
    return {
        "film": {"width": RES, "height": RES},
        "camera": {"position": [0, 1.6, 3.2], "target": [0, 0, 0], "fov": 45},
        "materials": {"metal": {"type": "conductor", "eta": [0.2, 0.4, 1.4], "k": [3.9, 2.4, 1.6],
                                "roughness": list(alphas)}},
        "shapes": [
            {"type": "rectangle", "material": "metal", "transform": steps},
            {"type": "rectangle", "emission": 8,
             "transform": [{"scale": 0.35}, {"look_at": {"origin": [0, 1.6, -1.4], "target": [0, 0, 0]}}]},
        ],
    }


def disk_scene(rotation_deg, turned_deg):
    """The plate as a disk (planar UVs, so turning it about its normal changes nothing but dp/du), alphas
    (0.04, 0.5), its anisotropy direction turned by `rotation_deg` and the disk itself by `turned_deg`."""
    d = plate_scene((0.04, 0.5), False)
    d["materials"]["metal"]["anisotropy_rotation"] = rotation_deg
    d["shapes"][0] = {"type": "disk", "material": "metal",
                      "transform": [{"scale": 1.5}, {"rotate": {"axis": [0, 0, 1], "angle": turned_deg}},
                                    {"rotate": {"axis": [1, 0, 0], "angle": -90}}]}
    return d


def test_turned_parameterisation_with_swapped_alphas_is_the_same_surface():
    seeds = range(1, 9)
    a = seeded_region_stats(caustica.load_dict(plate_scene((0.04, 0.5), False)), seeds, channel=1, spp=16)
    b = seeded_region_stats(caustica.load_dict(plate_scene((0.5, 0.04), True)), seeds, channel=1, spp=16)
    c = seeded_region_stats(caustica.load_dict(plate_scene((0.5, 0.04), False)), seeds, channel=1, spp=16)
    # Same surface: 16 regions, each within 4.5 standard errors of the difference (two-sided p ~ 7e-6 per
    # region, so a false alarm is rare).
    assert region_z(a, b).max() < 4.5, region_z(a, b)
    # The direction matters: swapping the alphas without turning the parameterisation stretches the
    # highlight the other way (if the frame ignored dp/du, a and b would differ like this).
    assert region_z(a, c).max() > 10.0, region_z(a, c)


@pytest.mark.parametrize("integrator,opts", [("light", {}), ("bdpt", {}), ("sppm", {"photons": 20000})])
def test_every_integrator_shades_with_the_same_frame(integrator, opts):
    """The light tracer and BDPT shade light vertices through the frame of their own hit, SPPM its visible
    points; each agrees with the path tracer on the anisotropic plate (SPPM within its bias: after 64
    passes its radius is small against the highlight)."""
    # The turned plate: its dp/du (world z) is not the first axis of the normal's own frame (world x), so
    # a stage that built its frame from the normal alone would stretch the highlight the other way.
    scene = caustica.load_dict(plate_scene((0.05, 0.45), True))
    seeds = range(1, 7)
    ref = seeded_region_stats(scene, seeds, channel=1, spp=32)
    spp = 64 if integrator == "sppm" else 32
    got = seeded_region_stats(scene, seeds, integrator=integrator, channel=1, spp=spp, **opts)
    z = region_z(ref, got)
    if integrator == "sppm":
        # Biased but consistent: compare relative differences of the regions that the highlight lights.
        lit = ref[0] > 0.2 * ref[0].max()
        rel = np.abs(got[0] - ref[0])[lit] / ref[0][lit]
        assert rel.max() < 0.15, rel
    else:
        assert z.max() < 4.5, z
    # And the same integrator on the swapped alphas differs (the frame is not ignored there).
    other = seeded_region_stats(caustica.load_dict(plate_scene((0.45, 0.05), True)), seeds, integrator=integrator,
                                 channel=1, spp=spp, **opts)
    assert region_z(got, other).max() > 6.0


def test_mitsuba_alpha_u_alpha_v(tmp_path):
    """Mitsuba XML's alpha_u / alpha_v become caustica's [alpha_x, alpha_y]; roughplastic has no anisotropy
    in Mitsuba 3, and a file that gives it one is an error naming the property."""
    xml = tmp_path / "aniso.xml"
    xml.write_text("""<scene version="3.0.0">
  <shape type="rectangle"><bsdf type="roughconductor"><string name="distribution" value="ggx"/>
    <float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.4"/></bsdf></shape>
  <sensor type="perspective"><transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
  </sensor><emitter type="constant"/></scene>""")
    out = tmp_path / "aniso.json"
    caustica.export_scene(str(xml), str(out))
    (mat,) = json.loads(out.read_text())["materials"].values()
    assert mat["type"] == "conductor"
    assert mat["roughness"] == pytest.approx([0.05, 0.4]), mat
    bad = tmp_path / "bad.xml"
    bad.write_text("""<scene version="3.0.0">
  <shape type="rectangle"><bsdf type="roughplastic"><float name="alpha_u" value="0.05"/>
    <float name="alpha_v" value="0.4"/></bsdf></shape></scene>""")
    with pytest.raises(caustica.SceneError, match=r"bad\.xml.*alpha_u.*isotropic"):
        caustica.load_scene(str(bad))


def test_anisotropy_rotation_turns_the_direction_towards_dp_dv():
    """anisotropy_rotation (degrees; glTF's anisotropyRotation in radians) turns alpha_x's direction from
    dp/du towards dp/dv, counter-clockwise seen from the normal: a disk whose direction is turned by +30
    degrees looks like the disk itself turned by +30 degrees about its normal, and not like -30."""
    seeds = range(1, 9)
    rotated = seeded_region_stats(caustica.load_dict(disk_scene(30, 0)), seeds, channel=1, spp=16)
    turned = seeded_region_stats(caustica.load_dict(disk_scene(0, 30)), seeds, channel=1, spp=16)
    mirrored = seeded_region_stats(caustica.load_dict(disk_scene(0, -30)), seeds, channel=1, spp=16)
    assert region_z(rotated, turned).max() < 4.5, region_z(rotated, turned)
    assert region_z(rotated, mirrored).max() > 10.0, region_z(rotated, mirrored)


def test_gltf_khr_materials_anisotropy(tmp_path):
    """KHR_materials_anisotropy: along the direction (dp/du turned by anisotropyRotation) alpha becomes
    mix(roughness^2, 1, strength^2), across it roughness^2 (the extension's definition); the JSON export
    keeps both alphas, the rotation in degrees and the anisotropyTexture."""
    import sys
    sys.path.insert(0, os.path.dirname(__file__))
    from test_gltf import Gltf, FILL_FOV, png_bytes
    g = Gltf()
    ext = {"anisotropyStrength": 0.8, "anisotropyRotation": math.pi / 6}
    mat = g.add("materials", {"pbrMetallicRoughness": {"metallicFactor": 1.0, "roughnessFactor": 0.3},
                              "extensions": {"KHR_materials_anisotropy": ext}})
    g.doc["extensionsUsed"] = ["KHR_materials_anisotropy"]
    g.scene([g.add("nodes", {"mesh": g.quad(mat)}), g.camera(3.0, FILL_FOV)])
    path = g.write(tmp_path / "aniso.gltf")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = tmp_path / "aniso.json"
        caustica.export_scene(path, str(out))
    assert not [w for w in caught if "anisotropy" in str(w.message)]  # supported: no "not supported" warning
    (m,) = json.loads(out.read_text())["materials"].values()
    a = 0.3 ** 2
    assert m["type"] == "metallic_roughness"
    assert m["alpha"] == pytest.approx([a * (1 - 0.64) + 0.64, a], rel=1e-6)
    assert m["anisotropy_rotation"] == pytest.approx(30.0, rel=1e-6)
    img = caustica.render(caustica.load_scene(str(out), width=16, height=16), spp=2)
    assert np.isfinite(img).all()
    ext["anisotropyTexture"] = {"index": 0}
    g.image_data_uri(png_bytes(np.full((2, 2, 3), 128, np.uint8)))
    g.add("textures", {"source": 0})
    out = tmp_path / "aniso_tex.json"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        caustica.export_scene(g.write(tmp_path / "aniso_tex.gltf"), str(out))
    assert not [w for w in caught if "anisotropy" in str(w.message)]
    (m,) = json.loads(out.read_text())["materials"].values()
    assert "texture" in m["anisotropy_texture"]


def tangent_quad(g, material, tangent=None):
    """g.quad with an optional TANGENT attribute ([tx, ty, tz, w] at every vertex)."""
    mesh = g.quad(material)
    if tangent is not None:
        prim = g.doc["meshes"][mesh]["primitives"][0]
        prim["attributes"]["TANGENT"] = g.accessor(list(tangent) * 4, "VEC4")
    return mesh


def gltf_module():
    import sys
    sys.path.insert(0, os.path.dirname(__file__))
    import test_gltf
    return test_gltf


def test_gltf_tangents_are_read_generated_and_exported(tmp_path):
    """glTF TANGENT becomes the mesh's vertex tangents for a material with anisotropy or a normal map; without
    it tangents are generated from the normals and UVs (on the quad: dp/du = +x, bitangent +y, so w = +1);
    a material that needs no tangent frame gets none; the JSON export keeps them, and a zero tangent is
    reported."""
    tg = gltf_module()

    def exported(tangent, ext=True, name="t"):
        g = tg.Gltf()
        m = {"pbrMetallicRoughness": {"metallicFactor": 1.0, "roughnessFactor": 0.5}}
        if ext:
            m["extensions"] = {"KHR_materials_anisotropy": {"anisotropyStrength": 0.9}}
            g.doc["extensionsUsed"] = ["KHR_materials_anisotropy"]
        mat = g.add("materials", m)
        g.scene([g.add("nodes", {"mesh": tangent_quad(g, mat, tangent)}), g.camera(3.0, tg.FILL_FOV)])
        out = tmp_path / (name + ".json")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            caustica.export_scene(g.write(tmp_path / (name + ".gltf")), str(out))
        doc = json.loads(out.read_text())
        (mesh,) = doc["meshes"].values() if "meshes" in doc else [s for s in doc["shapes"] if s["type"] == "mesh"]
        return mesh.get("tangents"), [str(w.message) for w in caught if "no lights" not in str(w.message)]

    t, said = exported([0, 1, 0, -1], name="read")
    assert t == [[0, 1, 0, -1]] * 4 and not said
    t, said = exported([0, 3, 0, 1], name="scaled")
    assert t == [[0, 1, 0, 1]] * 4  # normalised
    t, said = exported(None, name="generated")
    assert t == [[1, 0, 0, 1]] * 4 and not said
    t, said = exported([0, 1, 0, 1], ext=False, name="unused")
    assert t is None
    t, said = exported([0, 0, 0, 1], name="zero")
    assert t == [[0, 0, 0, 0]] * 4
    assert [m for m in said if "4 zero or non-finite tangents" in m], said


def test_gltf_tangent_orients_anisotropy_like_a_rotation(tmp_path):
    """A TANGENT along +y (dp/dv) turns the anisotropy direction a quarter, as anisotropyRotation = pi/2 does
    with the UVs' own dp/du: the highlights agree region by region, and differ from the unturned one."""
    tg = gltf_module()

    def scene(tangent, rotation):
        g = tg.Gltf()
        mat = g.add("materials", {"pbrMetallicRoughness": {"metallicFactor": 1.0, "roughnessFactor": 0.5},
                                  "extensions": {"KHR_materials_anisotropy": {"anisotropyStrength": 0.9,
                                                                              "anisotropyRotation": rotation}}})
        g.doc["extensionsUsed"] = ["KHR_lights_punctual", "KHR_materials_anisotropy"]
        g.doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 683.0 * 8}]}}
        light = g.add("nodes", {"translation": [0.2, 0.1, 1.2], "extensions": {"KHR_lights_punctual": {"light": 0}}})
        g.scene([g.add("nodes", {"mesh": tangent_quad(g, mat, tangent)}), light, g.camera(3.0, tg.FILL_FOV)])
        path = g.write(tmp_path / ("q%d.gltf" % len(list(tmp_path.iterdir()))))
        return caustica.load_scene(path, width=RES, height=RES)

    seeds = range(1, 9)
    by_tangent = seeded_region_stats(scene([0, 1, 0, 1], 0.0), seeds, channel=1, spp=16)
    by_rotation = seeded_region_stats(scene(None, math.pi / 2), seeds, channel=1, spp=16)
    unturned = seeded_region_stats(scene(None, 0.0), seeds, channel=1, spp=16)
    assert region_z(by_tangent, by_rotation).max() < 4.5, region_z(by_tangent, by_rotation)
    assert region_z(by_tangent, unturned).max() > 10.0, region_z(by_tangent, unturned)


def test_gltf_tangent_handedness_orients_the_normal_map(tmp_path):
    """A normal map whose texels tilt the normal towards +B (green up): with TANGENT w = +1 (B = +y, as the
    UVs' v) the tilted plane faces a lamp above its centre more where the lamp lies towards +y, i.e. on the
    half with y < 0; w = -1 turns B to -y and the brighter half with it; the generated tangents agree with
    w = +1."""
    tg = gltf_module()

    def render_plane(tangent):
        g = tg.Gltf()
        g.image_data_uri(tg.png_bytes(np.full((2, 2, 3), [128, 200, 220], np.uint8)))
        g.add("textures", {"source": 0})
        mat = g.add("materials", {"pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 1.0},
                                  "normalTexture": {"index": 0},
                                  "extensions": {"KHR_materials_ior": {"ior": 1.0}}})
        g.doc["extensionsUsed"] = ["KHR_lights_punctual", "KHR_materials_ior"]
        g.doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 683.0 * 4}]}}
        light = g.add("nodes", {"translation": [0, 0, 0.5], "extensions": {"KHR_lights_punctual": {"light": 0}}})
        g.scene([g.add("nodes", {"mesh": tangent_quad(g, mat, tangent)}), light, g.camera(3.0, tg.FILL_FOV)])
        path = g.write(tmp_path / ("n%d.gltf" % len(list(tmp_path.iterdir()))))
        img = caustica.render(caustica.load_scene(path, width=RES, height=RES), spp=8, seed=3)
        rows = img[:, :, 1].mean(axis=1)  # row 0 = the image top = +y
        return rows[RES // 2:].mean() / rows[:RES // 2].mean()  # the y < 0 half over the y > 0 half

    up, down, generated = render_plane([1, 0, 0, 1]), render_plane([1, 0, 0, -1]), render_plane(None)
    assert up > 1.3 and down < 1 / 1.3, (up, down)
    assert generated == pytest.approx(up, rel=1e-6)


def test_gltf_anisotropy_texture_turns_and_scales(tmp_path):
    """anisotropyTexture: (2r - 1, 2g - 1) turns the direction by its angle and b scales the strength, as the
    extension defines them: a constant texture renders as the same material with that rotation and strength
    written out (8-bit texels: r = 128 is 2 x 128/255 - 1, not 0), and differs from the untextured one."""
    tg = gltf_module()

    def scene(strength, rotation, texel=None):
        g = tg.Gltf()
        ext = {"anisotropyStrength": strength, "anisotropyRotation": rotation}
        if texel is not None:
            g.image_data_uri(tg.png_bytes(np.full((2, 2, 3), texel, np.uint8)))
            g.add("textures", {"source": 0})
            ext["anisotropyTexture"] = {"index": 0}
        mat = g.add("materials", {"pbrMetallicRoughness": {"metallicFactor": 1.0, "roughnessFactor": 0.5},
                                  "extensions": {"KHR_materials_anisotropy": ext}})
        g.doc["extensionsUsed"] = ["KHR_lights_punctual", "KHR_materials_anisotropy"]
        g.doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 683.0 * 8}]}}
        light = g.add("nodes", {"translation": [0.2, 0.1, 1.2], "extensions": {"KHR_lights_punctual": {"light": 0}}})
        g.scene([g.add("nodes", {"mesh": g.quad(mat)}), light, g.camera(3.0, tg.FILL_FOV)])
        path = g.write(tmp_path / ("a%d.gltf" % len(list(tmp_path.iterdir()))))
        return caustica.load_scene(path, width=RES, height=RES)

    half = 2 * 128 / 255 - 1
    seeds = range(1, 9)
    turned = seeded_region_stats(scene(0.9, 0.1, [128, 255, 255]), seeds, channel=1, spp=16)
    turned_ref = seeded_region_stats(scene(0.9, 0.1 + math.atan2(1, half)), seeds, channel=1, spp=16)
    weaker = seeded_region_stats(scene(0.9, 0.0, [255, 128, 128]), seeds, channel=1, spp=16)
    weaker_ref = seeded_region_stats(scene(0.9 * 128 / 255, math.atan2(half, 1)), seeds, channel=1, spp=16)
    plain = seeded_region_stats(scene(0.9, 0.1), seeds, channel=1, spp=16)
    assert region_z(turned, turned_ref).max() < 4.5, region_z(turned, turned_ref)
    assert region_z(weaker, weaker_ref).max() < 4.5, region_z(weaker, weaker_ref)
    assert region_z(turned, plain).max() > 10.0, region_z(turned, plain)
    assert region_z(weaker, plain).max() > 10.0, region_z(weaker, plain)
