"""Bump maps (JSON `bump_map`, Mitsuba's `bumpmap`) and the normal map's bitangent convention through the
Python API: a height map changes the image, the JSON export keeps `bump_map` and `"bitangent": "cross"`
(and validates against docs/scene.schema.json), and bad values are clear errors. The shading itself is
checked in C++ (Texture.BumpMapTiltsTheNormalAgainstTheSlope, Texture.NormalMapBitangentOnMirroredUVs) and
against Mitsuba 3 in bench/RESULTS.md ("bumpy")."""
import json
import math
import os

import jsonschema
import numpy as np
import pytest

import caustica

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def scene(tmp_path, material):
    n = 32
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    h = (0.5 + 0.5 * np.sin(xx * 2 * math.pi / 8) * np.sin(yy * 2 * math.pi / 8)).astype(np.float32)
    caustica.write_image(str(tmp_path / "h.exr"), np.repeat(h[:, :, None], 3, axis=2))
    caustica.write_image(str(tmp_path / "n.exr"), np.full((2, 2, 3), [0.5, 0.8, 0.9], np.float32))
    doc = {"film": {"width": 32, "height": 32},
           "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov": 40},
           "materials": {"m": material},
           "shapes": [{"type": "rectangle", "material": "m"},
                      {"type": "rectangle", "emission": 5,
                       "transform": [{"scale": 0.3}, {"look_at": {"origin": [-2, 0, 1], "target": [0, 0, 0]}}]}]}
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))
    return str(path)


def test_bump_map_changes_the_image_and_round_trips(tmp_path):
    flat = caustica.render(caustica.load_scene(scene(tmp_path, {"type": "diffuse"})), spp=16, seed=1)
    bumpy_path = scene(tmp_path, {"type": "diffuse", "bump_map": {"texture": "h.exr", "scale": 0.02}})
    bumpy = caustica.render(caustica.load_scene(bumpy_path), spp=16, seed=1)
    assert np.isfinite(bumpy).all()
    # The same seed: wherever the bumps tilt the normal the plane is lit differently (the slopes reach
    # 0.02 x 0.5 x 2 pi / 8 x 32 texels = 0.25).
    assert np.abs(bumpy - flat).mean() > 0.05 * flat.mean()
    out = tmp_path / "export.json"
    caustica.export_scene(bumpy_path, str(out))
    doc = json.loads(out.read_text())
    jsonschema.Draft202012Validator(json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))).validate(doc)
    (m,) = [v for v in doc["materials"].values() if "bump_map" in v]
    assert m["bump_map"]["scale"] == pytest.approx(0.02)
    again = caustica.render(caustica.load_scene(str(out)), spp=16, seed=1)
    np.testing.assert_array_equal(again, bumpy)


def test_normal_map_bitangent_round_trips(tmp_path):
    path = scene(tmp_path, {"type": "diffuse", "normal_map": {"texture": "n.exr", "bitangent": "cross"}})
    out = tmp_path / "export.json"
    caustica.export_scene(path, str(out))
    doc = json.loads(out.read_text())
    (m,) = [v for v in doc["materials"].values() if "normal_map" in v]
    assert m["normal_map"]["bitangent"] == "cross"
    path = scene(tmp_path, {"type": "diffuse", "normal_map": "n.exr"})
    caustica.export_scene(path, str(out))
    (m,) = [v for v in json.loads(out.read_text())["materials"].values() if "normal_map" in v]
    assert "bitangent" not in m["normal_map"]


@pytest.mark.parametrize("material, message", [
    ({"type": "diffuse", "normal_map": {"texture": "n.exr", "bitangent": "left"}},
     "/materials/m/normal_map/bitangent: unknown bitangent 'left' (allowed: uv, cross)"),
    ({"type": "diffuse", "reflectance": {"texture": "n.exr", "bitangent": "cross"}},
     "/materials/m/reflectance/bitangent: unknown key"),
    ({"type": "diffuse", "bump_map": "h.exr", "normal_map": "n.exr"},
     "/materials/m/bump_map: give normal_map or bump_map, not both"),
])
def test_errors(tmp_path, material, message):
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(scene(tmp_path, material))
    assert message in str(e.value)
