"""Direct lighting against closed forms, one light type at a time. A small camera with a
narrow field of view looks straight down at the origin of a large Lambertian floor of
albedo kd, so every pixel sees (nearly) the point at the origin, whose outgoing radiance
is kd / pi * E with E the irradiance there. max_depth = 2: emission + direct light only."""
import math

import numpy as np
import pytest

import caustica
from conftest import mean_and_se

KD = 0.5


def scene(lights=None, shapes=()):
    return {
        "camera": {"position": [0, 0, 10], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 0.05,
                   "width": 16, "height": 16},
        "filter": "box",
        "materials": {"floor": {"type": "diffuse", "reflectance": KD},
                      "black": {"type": "diffuse", "reflectance": 0.0}},
        "shapes": [{"type": "rectangle", "material": "floor", "transform": {"scale": [50, 50, 1]}}, *shapes],
        "lights": lights or [],
    }


def check(sc, expected, spp=64):
    img = caustica.render(sc, spp=spp, max_depth=2, seed=5)
    m, se = mean_and_se(img[..., 1])
    # The pixels see points within 0.005 of the origin; over that symmetric footprint E
    # varies at second order, (0.005 / 1)^2 < 3e-5 relative: the 1e-4 relative term covers
    # it (and float rounding) where se == 0 (delta lights have no noise here).
    assert abs(m - expected) <= 4 * se + 1e-4 * expected, (m, expected, se)


def test_point_light():
    h, d = 2.0, 1.0  # light at (d, 0, h)
    I = 7.0
    r2 = h * h + d * d
    E = I * (h / math.sqrt(r2)) / r2
    check(scene([{"type": "point", "position": [d, 0, h], "intensity": I}]), KD / math.pi * E)


def test_spot_light_inside_and_outside_cone():
    # Axis straight down from (0.5, 0, 2): the origin is 14.04 degrees off axis.
    off = math.degrees(math.atan2(0.5, 2.0))
    I = 5.0
    r2 = 0.25 + 4.0
    E = I * (2.0 / math.sqrt(r2)) / r2
    inside = {"type": "spot", "position": [0.5, 0, 2], "target": [0.5, 0, 0], "intensity": I,
              "cutoff_angle": 30, "falloff_start": 20}
    check(scene([inside]), KD / math.pi * E)
    outside = dict(inside, cutoff_angle=off - 1, falloff_start=off - 2)
    check(scene([outside]), 0.0)
    # In the falloff band: smoothstep of the cosine.
    band = dict(inside, cutoff_angle=off + 4, falloff_start=off - 4)
    ct, cs = math.cos(math.radians(off + 4)), math.cos(math.radians(off - 4))
    t = (math.cos(math.radians(off)) - ct) / (cs - ct)
    check(scene([band]), KD / math.pi * E * t * t * (3 - 2 * t))


def test_directional_light():
    E = 3.0
    dirn = np.array([1.0, 0.0, -2.0])
    cos = 2.0 / np.linalg.norm(dirn)
    check(scene([{"type": "directional", "direction": dirn.tolist(), "irradiance": E}]), KD / math.pi * E * cos)


def test_environment_light():
    # Upper hemisphere of constant radiance L: E = pi L, outgoing KD * L.
    L = 0.7
    check(scene([{"type": "environment", "radiance": L}]), KD * L, spp=256)


def test_sphere_area_light():
    # A sphere of radiance L, centre at distance D, fully above the horizon and off the
    # camera's line of sight: E = pi L sin^2(theta_max) cos(theta_axis), sin(theta_max) = R/D.
    L, R = 4.0, 0.3
    c = np.array([1.0, 0.0, 1.5])
    D = np.linalg.norm(c)
    E = math.pi * L * (R / D) ** 2 * (c[2] / D)
    sph = {"type": "sphere", "center": c.tolist(), "radius": R, "material": "black", "emission": L}
    check(scene(shapes=[sph]), KD / math.pi * E, spp=256)


def test_rectangle_area_light():
    # A small square emitter (side s) facing down at height h, centred at (x0, 0, h), off
    # the camera's line of sight: E = int L cos_r cos_l / r^2 dA = int L h^2 / r^4 dA,
    # by a 200x200 midpoint rule (error far below 1e-4 relative for this smooth integrand).
    L, h, s, x0 = 1000.0, 1.0, 0.05, 0.5
    n = 200
    xs = (np.arange(n) + 0.5) / n * s - s / 2
    X, Y = np.meshgrid(xs + x0, xs)
    r2 = X * X + Y * Y + h * h
    E = float(np.sum(L * (h * h) / (r2 * r2)) * (s / n) ** 2)
    rect = {"type": "rectangle", "material": "black", "emission": L,
            "transform": {"scale": [s / 2, s / 2, 1], "rotate": {"axis": [1, 0, 0], "angle": 180},
                          "translate": [x0, 0, h]}}
    check(scene(shapes=[rect]), KD / math.pi * E, spp=256)
