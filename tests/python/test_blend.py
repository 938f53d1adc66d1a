"""Blends (JSON `blend`, Mitsuba's blendbsdf; scene/shading.h): the surface is one of two materials at each
point, the second at a share `weight`, so a lit floor of blend(albedo 0.2, albedo 0.8; 0.25) has the radiance
of albedo 0.35 for every integrator (analytic; the spread over seeds gives the standard error). The scene
format's checks and the export round trip."""
import json
import math
import os

import jsonschema
import numpy as np
import pytest

import caustica
from test_opacity import INTEGRATORS, INTEGRATOR_IDS, mean_over_seeds

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RES = 16


def blended_floor(weight=0.25, nested=False):
    # A floor under a directional light of irradiance pi straight down, seen from above: radiance = albedo.
    mats = {"dark": {"type": "diffuse", "reflectance": 0.2}, "light": {"type": "diffuse", "reflectance": 0.8},
            "floor": {"type": "blend", "materials": ["dark", "light"], "weight": weight}}
    if nested:  # blend(dark, blend(light, mirror; 0.5); w): the mirror sees the black sky
        mats["shiny"] = {"type": "blend", "materials": ["light", "mirror"], "weight": 0.5}
        mats["mirror"] = {"type": "conductor"}
        mats["floor"]["materials"] = ["dark", "shiny"]
    return {
        "camera": {"position": [0, 0, 10], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 20,
                   "width": RES, "height": RES},
        "materials": mats,
        "shapes": [{"type": "rectangle", "material": "floor", "transform": {"scale": 5}}],
        "lights": [{"type": "directional", "direction": [0, 0, -1], "irradiance": math.pi}],
    }


@pytest.mark.parametrize("integrator,opts", INTEGRATORS, ids=INTEGRATOR_IDS)
@pytest.mark.parametrize("nested", [False, True], ids=["blend", "nested"])
def test_a_blended_floor_has_the_mixed_albedo(integrator, opts, nested):
    # 0.75 x 0.2 + 0.25 x 0.8 = 0.35; nested: 0.75 x 0.2 + 0.25 x (0.5 x 0.8 + 0.5 x 0) = 0.25.
    expected = 0.25 if nested else 0.35
    m, se = mean_over_seeds(blended_floor(nested=nested), integrator, range(1, 7), **opts)
    assert se < 0.01, (integrator, se)
    assert abs(m - expected) < 4.5 * se, (integrator, m, expected, se)  # Student t, 5 degrees of freedom


def test_blend_weights_at_the_ends_are_the_materials():
    for w, albedo in [(0.0, 0.2), (1.0, 0.8)]:
        img = caustica.render(blended_floor(weight=w), spp=4, seed=1)
        np.testing.assert_allclose(img[..., 1], albedo, rtol=1e-5)


def test_blend_errors(tmp_path):
    def err(floor, extra=None):
        doc = blended_floor()
        doc["materials"]["floor"] = floor
        doc["materials"].update(extra or {})
        p = tmp_path / "bad.json"
        p.write_text(json.dumps(doc))
        with pytest.raises(caustica.SceneError) as e:
            caustica.load_scene(str(p))
        return str(e.value)

    assert "/materials/floor/materials/1: unknown material 'nowhere'" in err(
        {"type": "blend", "materials": ["dark", "nowhere"]})
    assert "/materials/floor/materials: expected two material names" in err(
        {"type": "blend", "materials": ["dark"]})
    assert "/materials/floor/materials: a blend may not contain itself" in err(
        {"type": "blend", "materials": ["dark", "other"]},
        {"other": {"type": "blend", "materials": ["floor", "light"]}})
    assert "/materials/floor/weight: expected a number in [0, 1]" in err(
        {"type": "blend", "materials": ["dark", "light"], "weight": 2})
    assert "/materials/floor/two_sided: unknown key" in err(
        {"type": "blend", "materials": ["dark", "light"], "two_sided": True})


def test_export_keeps_the_blend(tmp_path):
    caustica.write_image(str(tmp_path / "w.exr"), np.array([[[1, 1, 1], [0.25, 0.25, 0.25]]], np.float32))
    doc = blended_floor(nested=True)
    doc["materials"]["floor"]["weight"] = {"texture": "w.exr", "scale": 0.8, "filter": "nearest"}
    src = tmp_path / "blend.json"
    src.write_text(json.dumps(doc))
    out = tmp_path / "export.json"
    caustica.export_scene(str(src), str(out))
    exported = json.loads(out.read_text())
    jsonschema.Draft202012Validator(json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))).validate(exported)
    blends = {k: v for k, v in exported["materials"].items() if v["type"] == "blend"}
    assert len(blends) == 2
    assert exported["materials"]["floor"]["materials"] == ["dark", "shiny"]
    assert exported["materials"]["floor"]["weight"]["scale"] == pytest.approx(0.8)
    a = caustica.render(caustica.load_scene(str(src)), spp=4, seed=1)
    b = caustica.render(caustica.load_scene(str(out)), spp=4, seed=1)
    np.testing.assert_array_equal(a, b)
