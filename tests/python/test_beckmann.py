"""The Beckmann microfacet distribution of rough conductors and dielectrics (material/microfacet.h; Mitsuba's
default `distribution`): JSON spells it, `caustica export` writes it back (valid against docs/scene.schema.json)
and the export renders the same image; Mitsuba XML without a distribution gets it; path, BDPT and VCM agree
on Beckmann metals and glass, each on a plate; a bad name is an error. D, Lambda and sampling are checked in
tests/cpp/test_bsdf.cpp (normalization, the projected-area identity, chi-square, weights, albedo), and a whole
Mitsuba scene against Mitsuba 3.9.1 in bench/RESULTS.md ("beckmann")."""
import json
import os
import warnings

import jsonschema
import numpy as np
import pytest

import caustica

from conftest import plate_cross_check, sphere_row

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def scene(dist="beckmann"):
    mats = {"gold": {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603],
                     "roughness": 0.2, "distribution": dist},
            "brushed": {"type": "conductor", "specular": [0.9, 0.6, 0.4], "roughness": [0.05, 0.4],
                        "distribution": dist},
            "glass": {"type": "dielectric", "eta": 1.5, "roughness": 0.25, "distribution": dist},
            "floor": {"type": "diffuse", "reflectance": 0.5}}
    return sphere_row(mats, "floor", ["gold", "brushed", "glass"])


# A variant of each of scene()'s materials: another roughness, the brushed metal's alphas swapped.
VARIANTS = {"gold": {"roughness": 0.3}, "brushed": {"roughness": [0.4, 0.05]}, "glass": {"roughness": 0.1}}


@pytest.mark.parametrize("integrator", ["bdpt", "vcm"])
@pytest.mark.parametrize("material", VARIANTS)
def test_integrators_agree_with_the_path_tracer(integrator, material):
    """Light subpaths sample and evaluate the Beckmann lobes in importance mode: each material on the lamp-lit
    plate (the glass over a floor, which the light through it reaches), the integrator against the path tracer
    per region within 4.5 standard errors over 16 seeds (VCM's merging included), and more than 10 from the
    variant, so that the check can fail. Measured: 1.5-3.2 and 23-146."""
    m = scene()["materials"][material]
    agree, differ = plate_cross_check(m, dict(m, **VARIANTS[material]), integrator, floor=material == "glass",
                                      max_depth=8)
    assert agree < 4.5, (integrator, material, agree)
    assert differ > 10.0, (integrator, material, differ)


def test_json_export_round_trip(tmp_path):
    f = tmp_path / "s.json"
    f.write_text(json.dumps(scene()))
    out = tmp_path / "e.json"
    caustica.export_scene(str(f), str(out))
    doc = json.loads(out.read_text())
    jsonschema.Draft202012Validator(json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))).validate(doc)
    dists = {k: m.get("distribution") for k, m in doc["materials"].items()}
    assert dists["gold"] == dists["brushed"] == dists["glass"] == "beckmann" and dists["floor"] is None
    assert np.array_equal(caustica.render(str(f), spp=8, seed=5), caustica.render(str(out), spp=8, seed=5))


def test_mitsuba_default_is_beckmann(tmp_path):
    xml = tmp_path / "b.xml"
    body = ('<shape type="sphere"><bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf></shape>'
            '<shape type="sphere"><point name="center" x="3"/><bsdf type="roughdielectric">'
            '<string name="distribution" value="ggx"/></bsdf></shape>'
            '<shape type="sphere"><point name="center" x="6"/><bsdf type="roughplastic"/></shape>'
            '<emitter type="constant"/>')
    xml.write_text(f'<scene version="3.0.0">{body}</scene>')
    out = tmp_path / "b.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no sensor: Mitsuba's default camera
        caustica.export_scene(str(xml), str(out))
    doc = json.loads(out.read_text())
    jsonschema.Draft202012Validator(json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))).validate(doc)
    dist = {m["type"]: m.get("distribution", "ggx") for m in doc["materials"].values()}
    assert dist == {"conductor": "beckmann", "dielectric": "ggx", "plastic": "beckmann"}, dist
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert np.array_equal(caustica.render(str(xml), spp=4, seed=2), caustica.render(str(out), spp=4, seed=2))


def test_bad_distribution_is_an_error(tmp_path):
    s = scene("phong")
    f = tmp_path / "s.json"
    f.write_text(json.dumps(s))
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(str(f))
    assert str(e.value) == (f"{f}: /materials/gold/distribution: unknown distribution 'phong' "
                            "(allowed: ggx, beckmann)")
