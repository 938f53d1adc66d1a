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


@pytest.mark.parametrize("statement,key", [("bump -bm 0.02 h.exr", "bump_map"), ("map_Bump -bm 0.8 nm.exr", "normal_map"),
                                           ("norm nm.exr", "normal_map")])
def test_obj_mtl_bump_and_normal_maps(tmp_path, statement, key):
    # OBJ + MTL: `bump` with a height map is a bump map; `map_Bump` with a normal map's texels (Blender writes
    # them there) and `norm` are normal maps. The lit quad changes, and the JSON export keeps the map and its
    # scale and renders the same image.
    scene(tmp_path, {"type": "diffuse"})  # writes h.exr
    # A normal map tilting the normal towards -u (away from the lamp): tangent-space (-0.3, 0.1, 0.95).
    caustica.write_image(str(tmp_path / "nm.exr"), np.full((4, 4, 3), [0.35, 0.55, 0.975], np.float32))
    (tmp_path / "q.mtl").write_text(f"newmtl flat\nKd 0.5\nnewmtl mapped\nKd 0.5\n{statement}\n")
    quad = ("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
            "f 1/1/1 2/2/1 3/3/1 4/4/1\n")
    light = ("v -1.6 0 0.6\nv -1.7 0 1.4\nv -1.7 0.4 1.4\nv -1.6 0.4 0.6\n"
             "usemtl lamp\nf 5 6 7 8\nf 8 7 6 5\n")
    (tmp_path / "q.mtl").write_text((tmp_path / "q.mtl").read_text() + "newmtl lamp\nKe 5 5 5\nKd 0\n")
    imgs = {}
    for mat in ("flat", "mapped"):
        (tmp_path / f"{mat}.obj").write_text(f"mtllib q.mtl\nusemtl {mat}\n{quad}{light}")
        doc = {"film": {"width": 32, "height": 32}, "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov": 40},
               "shapes": [{"type": "mesh", "file": f"{mat}.obj"}]}
        (tmp_path / f"{mat}.json").write_text(json.dumps(doc))
        with pytest.warns(caustica.SceneWarning) if "map_Bump" in statement and mat == "mapped" else _no_warning():
            imgs[mat] = caustica.render(caustica.load_scene(str(tmp_path / f"{mat}.json")), spp=16, seed=2)
    assert np.isfinite(imgs["mapped"]).all()
    assert np.abs(imgs["mapped"] - imgs["flat"]).mean() > 0.02 * imgs["flat"].mean()
    out = tmp_path / "export.json"
    caustica.export_scene(str(tmp_path / "mapped.json"), str(out))
    exported = json.loads(out.read_text())
    (m,) = [v for v in exported["materials"].values() if key in v]
    scale = {"bump -bm 0.02 h.exr": 0.02, "map_Bump -bm 0.8 nm.exr": 0.8, "norm nm.exr": 1.0}[statement]
    assert m[key].get("scale", 1.0) == pytest.approx(scale)
    again = caustica.render(caustica.load_scene(str(out)), spp=16, seed=2)
    np.testing.assert_array_equal(again, imgs["mapped"])


class _no_warning:
    def __enter__(self):
        import warnings
        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("error", caustica.SceneWarning)

    def __exit__(self, *a):
        return self._w.__exit__(*a)
