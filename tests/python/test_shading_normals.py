"""Shading normals make scattering asymmetric (Veach 1997, Sec. 5.3.2): light subpaths and photons carry
the adjoint BSDF, f(wi -> wo) |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|), and a photon density estimate weighs each
photon with |wi.ns| / |wi.ng| (scene/shading.h: shading_normal_adjoint, photon_gather_cosines). Without them
the light tracer, BDPT and VCM disagree with the path tracer on smooth-shaded meshes (an 8 x 6 facet
sphere: light tracing 4.8% darker, 20 standard errors; BDPT 1.4% darker) and on normal maps.
Here they agree on both, region by region, within the standard error of the difference of independent
renders (fixed seeds)."""
import json
import math
import os

import numpy as np
import pytest

import caustica
from conftest import region_z, seeded_region_stats

RES = 32


def faceted_sphere():
    """A low-poly UV sphere (8 x 6 quads) with the true sphere's normals at its vertices."""
    nu, nv = 8, 6
    P, I = [], []
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu + 1):
            ph = 2 * math.pi * i / nu
            P.append([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])
    for j in range(nv):
        for i in range(nu):
            a = j * (nu + 1) + i
            b = a + nu + 1
            I += [a, b, a + 1, a + 1, b, b + 1]
    return P, I


def scene(tmp_path, normal_map):
    P, I = faceted_sphere()
    mat = {"type": "diffuse", "reflectance": 0.7}
    shapes = [{"type": "mesh", "positions": P, "normals": P, "indices": I, "material": "d"}]
    if normal_map:
        # Tiles tilted by about 20 degrees in alternating directions on a plate (rectangle UVs).
        n = 16
        yy, xx = np.mgrid[0:n, 0:n] + 0.5
        tx = np.where((xx // 4) % 2 == 0, 0.35, -0.35)
        img = np.stack([0.5 * tx + 0.5, np.full_like(tx, 0.5), 0.5 * np.sqrt(1 - tx ** 2) + 0.5], axis=2)
        caustica.write_image(str(tmp_path / "tiles.exr"), img.astype(np.float32))
        mat = dict(mat, normal_map={"texture": "tiles.exr", "filter": "nearest"})
        shapes = [{"type": "rectangle", "material": "d", "transform": [{"rotate": {"axis": [1, 0, 0], "angle": 60}}]}]
    doc = {"film": {"width": RES, "height": RES},
           "camera": {"position": [0, -4, 1.5], "target": [0, 0, 0.3], "up": [0, 0, 1], "fov": 40},
           "materials": {"d": mat, "floor": {"type": "diffuse", "reflectance": 0.5}},
           "shapes": shapes + [
               {"type": "rectangle", "material": "floor", "transform": [{"scale": 4}, {"translate": [0, 0, -1]}]},
               {"type": "rectangle", "emission": 10,
                "transform": [{"scale": 0.5}, {"look_at": {"origin": [1.5, -1, 3], "target": [0, 0, 0]}}]}]}
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))
    return caustica.load_scene(str(path))


@pytest.mark.filterwarnings("ignore:.*degenerate.*")  # the UV sphere's pole triangles
@pytest.mark.parametrize("normal_map", [False, True], ids=["smooth-normals", "normal-map"])
def test_bidirectional_integrators_agree_with_path_tracing(tmp_path, normal_map):
    s = scene(tmp_path, normal_map)
    seeds = range(1, 9)
    ref = seeded_region_stats(s, seeds, integrator="path", spp=64)
    for integrator, spp in [("light", 64), ("bdpt", 16), ("vcm", 16)]:
        z = region_z(seeded_region_stats(s, seeds, integrator=integrator, spp=spp), ref)
        # 16 regions x 3 integrators: 4.5 standard errors keeps a false alarm below 1e-3 per test.
        assert z.max() < 4.5, (integrator, z.max(), z)
