"""Rough plastic (material/rough_plastic.h; Mitsuba's roughplastic): JSON spells it ("plastic" with a "roughness"),
Mitsuba XML's roughplastic loads as it, `caustica export` writes it back (valid against docs/scene.schema.json) and
the export renders the same image; path, BDPT and VCM agree on each of three rough plastics on a plate; a head-on
view of a black-based rough plastic under a white sky reflects exactly its coat's albedo, which the same coat as a
rough dielectric's reflection (a rough mirror tinted by nothing) also gives. Against Mitsuba 3.9.1's own values in
tests/cpp/test_rough_plastic.cpp and its renders in bench/RESULTS.md ("plastics")."""
import json
import os
import warnings

import jsonschema
import numpy as np
import pytest

import caustica

from conftest import mean_and_se, plate_cross_check, sphere_row, white_sky_plate

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def scene(dist="ggx"):
    mats = {"floor": {"type": "plastic", "diffuse": [0.5, 0.5, 0.5], "roughness": 0.3, "distribution": dist},
            "red": {"type": "plastic", "diffuse": [0.7, 0.2, 0.1], "roughness": 0.1, "distribution": dist},
            "blue": {"type": "plastic", "diffuse": [0.2, 0.3, 0.8], "roughness": 0.5, "eta": 1.33,
                     "specular": [0.8, 0.9, 1.0], "distribution": dist}}
    return sphere_row(mats, "floor", ["red", "blue"], radius=0.6, spacing=1.4)


# A variant of each of scene()'s materials: another roughness, or the blue's other IOR.
VARIANTS = {"floor": {"roughness": 0.15}, "red": {"roughness": 0.2}, "blue": {"eta": 1.6}}


@pytest.mark.parametrize("integrator,dist", [("bdpt", "ggx"), ("vcm", "beckmann")])
@pytest.mark.parametrize("material", VARIANTS)
def test_integrators_agree_with_the_path_tracer(integrator, dist, material):
    """Each rough plastic on the lamp-lit plate: the integrator against the path tracer per region within 4.5
    standard errors over 16 seeds (VCM's merging included), and more than 10 from the variant, so that the check
    can fail. Measured: 1.5-2.5 and 56-123."""
    m = scene(dist)["materials"][material]
    agree, differ = plate_cross_check(m, dict(m, **VARIANTS[material]), integrator, max_depth=6)
    assert agree < 4.5, (integrator, material, agree)
    assert differ > 10.0, (integrator, material, differ)


def test_black_base_reflects_the_coat_alone():
    # Diffuse 0: only the coat's lobe, F D G / (4 cos cos), which is a rough dielectric's reflection: the same
    # image as that glass seen head-on over black (max depth 2: the light refracted into the glass is lost), by
    # 4 standard errors of the difference.
    coat = white_sky_plate({"type": "plastic", "diffuse": 0.0, "roughness": 0.3, "eta": 1.5})
    glass = white_sky_plate({"type": "dielectric", "roughness": 0.3, "eta": 1.5})
    glass["shapes"].append({"type": "rectangle", "material": "black",
                            "transform": {"scale": 5, "translate": [0, 0, -0.01]}})
    glass["materials"]["black"] = {"type": "diffuse", "reflectance": 0.0}
    a = caustica.render(coat, spp=512, seed=1, max_depth=2, sampler="independent")[..., 1]
    b = caustica.render(glass, spp=512, seed=2, max_depth=2, sampler="independent")[..., 1]
    ma, sa = mean_and_se(a)
    mb, sb = mean_and_se(b)
    assert 0.02 < ma < 0.06, ma  # about the Fresnel reflectance at normal incidence, 0.04
    assert abs(ma - mb) < 4 * np.hypot(sa, sb), (ma, mb, sa, sb)


def test_json_and_mitsuba_round_trip(tmp_path):
    xml = tmp_path / "p.xml"
    xml.write_text('<scene version="3.0.0"><shape type="sphere"><bsdf type="roughplastic">'
                   '<rgb name="diffuse_reflectance" value="0.6, 0.3, 0.2"/><float name="alpha" value="0.25"/>'
                   '<rgb name="specular_reflectance" value="0.9"/></bsdf></shape>'
                   '<emitter type="constant"/></scene>')
    out = tmp_path / "p.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no sensor
        caustica.export_scene(str(xml), str(out))
        doc = json.loads(out.read_text())
        jsonschema.Draft202012Validator(json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))).validate(doc)
        (mat,) = [m for m in doc["materials"].values() if m["type"] == "plastic"]
        assert mat["roughness"] == 0.25 and mat["distribution"] == "beckmann", mat  # Mitsuba's default
        assert np.array_equal(caustica.render(str(xml), spp=8, seed=3), caustica.render(str(out), spp=8, seed=3))


def test_bad_roughness_is_an_error(tmp_path):
    f = tmp_path / "s.json"
    f.write_text(json.dumps(white_sky_plate({"type": "plastic", "roughness": -0.1})))
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(str(f))
    assert str(e.value) == (f"{f}: /materials/m/roughness: expected a GGX alpha >= 0 (a number: rough plastic is "
                            "isotropic)")
