"""A different material on each side of a surface: JSON "two_sided" (materials [front, back]) and Mitsuba's
twosided of two BSDFs (Material kSides, resolved per hit in scene/interaction.h).

The furnace: a square plate under a white sky of radiance 1 seen from in front and from behind; a diffuse side
of albedo a then has radiance a exactly (its hemisphere sees only the sky), so each side shows its own colour
(the back's as if seen from its own front), with every integrator."""
import json
import math
import os

import jsonschema
import numpy as np
import pytest

import caustica

RED, GREEN = [0.8, 0.2, 0.1], [0.15, 0.7, 0.3]


def plate(side, front="red", back="green"):
    z = 10 if side == "front" else -10
    return {"camera": {"position": [0, 0, z], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 3, "width": 16,
                       "height": 16},
            "materials": {"red": {"type": "diffuse", "reflectance": RED},
                          "green": {"type": "diffuse", "reflectance": GREEN},
                          "m": {"type": "two_sided", "materials": [front, back]}},
            "shapes": [{"type": "rectangle", "material": "m", "transform": {"scale": 5}}],
            "lights": [{"type": "environment", "radiance": 1.0}]}


@pytest.mark.parametrize("integrator", ["path", "bdpt", "light", "vcm", "sppm"])
@pytest.mark.parametrize("side", ["front", "back"])
def test_each_side_shows_its_own_material(integrator, side):
    img = caustica.render(plate(side), integrator=integrator, spp=64, max_depth=4, seed=3)
    px = img.reshape(-1, 3)
    mean, se = px.mean(axis=0), px.std(axis=0, ddof=1) / math.sqrt(len(px))
    expected = np.array(RED if side == "front" else GREEN)
    # 256 pixels, independent: 4.5 standard errors of their mean per channel; sppm and vcm also merge photons
    # within a radius that shrinks over the passes (a bias of the photon density near the plate's edge, far
    # from the 0.5-wide patch seen, and of the radius itself): 2% of the value besides for them.
    slack = 0.02 * expected if integrator in ("sppm", "vcm") else 0.0
    assert np.all(np.abs(mean - expected) < 4.5 * se + slack), (integrator, side, mean, expected, se)


def test_the_pair_order_matters_and_a_one_sided_back_is_black():
    front = caustica.render(plate("front", "green", "red"), spp=16, seed=1).mean(axis=(0, 1))
    assert np.allclose(front, GREEN, rtol=0.05), front
    s = plate("back")
    s["shapes"][0]["material"] = "red"  # one-sided diffuse: black from behind
    assert caustica.render(s, spp=16, seed=1).max() == 0.0


def test_errors_and_export(tmp_path):
    s = plate("front")
    s["materials"]["glass"] = {"type": "dielectric", "eta": 1.5}
    s["materials"]["m"]["materials"] = ["red", "glass"]
    with pytest.raises(caustica.InputError, match=r"/materials/m/materials: a two_sided material's materials must "
                                                  r"reflect only \('glass' transmits or is null\)"):
        caustica.load_scene(s)
    s["materials"]["m"] = {"type": "two_sided", "materials": ["red"]}
    with pytest.raises(caustica.InputError, match=r"/materials/m/materials: expected two material names \[front, back\]"):
        caustica.load_scene(s)
    s["materials"]["m"] = {"type": "two_sided", "materials": ["red", "green"], "weight": 0.5}
    with pytest.raises(caustica.InputError, match=r"/materials/m/weight: unknown key"):
        caustica.load_scene(s)
    f, out = tmp_path / "s.json", tmp_path / "e.json"
    f.write_text(json.dumps(plate("back")))
    caustica.export_scene(str(f), str(out))
    doc = json.loads(out.read_text())
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    jsonschema.Draft202012Validator(json.load(open(os.path.join(root, "docs", "scene.schema.json")))).validate(doc)
    assert doc["materials"]["m"] == {"type": "two_sided", "materials": ["red", "green"]}
    assert np.array_equal(caustica.render(str(f), spp=4, seed=5), caustica.render(str(out), spp=4, seed=5))


def test_mitsuba_twosided_of_two_bsdfs(tmp_path):
    xml = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="3"/>
    <transform name="to_world"><lookat origin="0, 0, {z}" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film></sensor>
  <shape type="rectangle"><transform name="to_world"><scale value="5"/></transform>
    <bsdf type="twosided">
      <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.1"/></bsdf>
      <bsdf type="diffuse"><rgb name="reflectance" value="0.15, 0.7, 0.3"/></bsdf>
    </bsdf></shape>
  <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>
"""
    for z, expected in ((10, RED), (-10, GREEN)):
        f = tmp_path / f"s{z}.xml"
        f.write_text(xml.format(z=z))
        img = caustica.render(str(f), spp=64, seed=2)
        px = img.reshape(-1, 3)
        se = px.std(axis=0, ddof=1) / math.sqrt(len(px))
        assert np.all(np.abs(px.mean(axis=0) - expected) < 4.5 * se), (z, px.mean(axis=0))
    f = tmp_path / "bad.xml"
    f.write_text(xml.format(z=10).replace('<bsdf type="diffuse"><rgb name="reflectance" value="0.15, 0.7, 0.3"/></bsdf>',
                                          '<bsdf type="dielectric"/>'))
    with pytest.raises(caustica.InputError, match="twosided applies to reflecting BSDFs only"):
        caustica.load_scene(str(f))
