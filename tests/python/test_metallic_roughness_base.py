"""The metallic-roughness dielectric's diffuse base (material/metallic_roughness.h): glTF's, base/pi (1 - F(cos_o))
(1 - F(cos_i)), so that a glTF base colour looks as bright as in glTF viewers; the plastic base (internal
reflections, 1/eta^2) only with "diffuse_base": "plastic" (Mitsuba's roughplastic). Checked against the
analytic diffuse part under a white sky: image(base) - image(base 0) = base (1 - F(1)) (1 - 2 int F(mu) mu dmu)."""
import math

import numpy as np

import caustica

from conftest import white_sky_plate


def fresnel(mu, eta=1.5):
    s = math.sqrt(max(0.0, 1 - (1 - mu * mu) / (eta * eta)))
    rs = (mu - eta * s) / (mu + eta * s)
    rp = (eta * mu - s) / (eta * mu + s)
    return 0.5 * (rs * rs + rp * rp)


def plate(base, diffuse_base=None):
    mat = {"type": "metallic_roughness", "base_color": base, "roughness": 1.0}
    if diffuse_base:
        mat["diffuse_base"] = diffuse_base
    return white_sky_plate(mat)


def mean_se(scene):
    g = caustica.render(scene, spp=256, seed=1, max_depth=2, sampler="independent")[..., 1].astype(np.float64)
    return g.mean(), g.std(ddof=1) / math.sqrt(g.size)  # independent pixels


def test_gltf_base_under_a_white_sky():
    n = 20000
    f_hemi = 2 * sum(fresnel((i + 0.5) / n) * (i + 0.5) / n for i in range(n)) / n
    diffuse = 0.5 * (1 - fresnel(1.0)) * (1 - f_hemi)  # 0.436
    spec, spec_se = mean_se(plate(0.0))
    full, full_se = mean_se(plate(0.5))
    assert abs(full - spec - diffuse) < 4.5 * math.hypot(spec_se, full_se), (full, spec, diffuse)
    # The plastic base is ~0.6 x as bright: 1 / (eta^2 (1 - 0.5 Fdr)) of the glTF one.
    plastic, _ = mean_se(plate(0.5, "plastic"))
    assert plastic - spec < 0.7 * diffuse
