import os
import sys

import numpy as np
import pytest

# The command line: the one installed beside this Python, or CAUSTICA_BIN (the GPU bundle's wrapper).
BIN = os.environ.get("CAUSTICA_BIN") or os.path.join(os.path.dirname(sys.executable), "caustica")


def srgb_to_linear(c):
    """The sRGB transfer function's inverse (IEC 61966-2-1) of values in [0, 1]."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def mean_and_se(values):
    """Mean and standard error of independent estimates."""
    v = np.asarray(values, dtype=np.float64).ravel()
    return v.mean(), v.std(ddof=1) / np.sqrt(v.size)


def seeded_rows(scene, integrator, seeds=(1, 2), **opts):
    """The green channel of renders with the independent sampler, one per seed, stacked row-wise:
    shape (len(seeds) * H, W), each row an independent estimate of the scene's row profile."""
    import caustica
    imgs = [caustica.render(scene, integrator=integrator, seed=s, sampler="independent", **opts) for s in seeds]
    return np.concatenate([im[:, :, 1] for im in imgs], axis=0).astype(np.float64)


def sphere_row(materials, floor, spheres, radius=0.55, spacing=1.2):
    """A rectangle floor of material `floor`, spheres of the named materials in a row along x (`spacing` apart,
    resting on the floor), an area light at the left and a dim sky, seen from (0, 2, 6) at 32 x 32: the scene the
    material tests render with several integrators."""
    shapes = [{"type": "rectangle", "material": floor,
               "transform": {"scale": 3, "rotate": {"axis": [1, 0, 0], "angle": -90}}}]
    for i, name in enumerate(spheres):
        shapes.append({"type": "sphere", "material": name, "radius": radius,
                       "center": [(i - (len(spheres) - 1) / 2) * spacing, radius, 0]})
    shapes.append({"type": "rectangle", "emission": [30, 28, 24],
                   "transform": {"scale": 0.5, "rotate": {"axis": [0, 0, 1], "angle": -70}, "translate": [-3, 1, 1]}})
    return {"camera": {"position": [0, 2, 6], "target": [0, 0.7, 0], "up": [0, 1, 0], "fov": 40, "width": 32,
                       "height": 32},
            "materials": materials, "shapes": shapes,
            "lights": [{"type": "environment", "radiance": [0.2, 0.22, 0.25]}]}


def region_means(img, k=8):
    """Green-channel means of a k x k grid of regions and their standard errors (from each region's pixel spread,
    which bounds the noise from above)."""
    h = img.shape[0] // k
    r = np.asarray(img, np.float64)[:h * k, :h * k, 1].reshape(k, h, k, h)
    return r.mean(axis=(1, 3)), r.std(axis=(1, 3), ddof=1) / h


def lamp_plate(material, name="plate", res=32, floor=False):
    """A plate of `material` (named `name`) filling most of a res x res view under a rectangular lamp, seen
    obliquely: the scene the material tests compare integrators and devices on with seeded_region_stats. With
    `floor`, a grey diffuse floor 0.4 below the plate that light through a transmissive plate reaches."""
    d = {
        "film": {"width": res, "height": res},
        "camera": {"position": [0, 1.2, 3.2], "target": [0, 0, 0], "fov": 45},
        "materials": {name: material},
        "shapes": [
            {"type": "rectangle", "material": name,
             "transform": [{"scale": 1.5}, {"rotate": {"axis": [1, 0, 0], "angle": -90}}]},
            {"type": "rectangle", "emission": 6,
             "transform": [{"scale": 0.4}, {"look_at": {"origin": [0, 1.4, -1.6], "target": [0, 0, 0]}}]},
        ],
    }
    if floor:
        d["materials"]["lamp_plate_floor"] = {"type": "diffuse", "reflectance": 0.5}
        d["shapes"].append({"type": "rectangle", "material": "lamp_plate_floor",
                            "transform": [{"scale": 3}, {"rotate": {"axis": [1, 0, 0], "angle": -90}},
                                          {"translate": [0, -0.4, 0]}]})
    return d


def plate_cross_check(material, variant, integrator, reference="path", device="cpu", seeds=16, spp=32, floor=False,
                      **opts):
    """Renders lamp_plate(material) with `integrator` on `device` and, with other seeds, with `reference` on the
    CPU, and lamp_plate(variant) with `reference` on the CPU (seeded_region_stats, `seeds` renders each): returns
    the largest region_z of the first against the second (below 4.5 when they agree) and against the variant
    (above 10 when the check can tell the two materials apart)."""
    import caustica
    scene = caustica.load_dict(lamp_plate(material, floor=floor))
    got = seeded_region_stats(scene, range(101, 101 + seeds), integrator=integrator, spp=spp, device=device, **opts)
    ref = seeded_region_stats(scene, range(1, 1 + seeds), integrator=reference, spp=spp, **opts)
    other = seeded_region_stats(caustica.load_dict(lamp_plate(variant, floor=floor)), range(1, 1 + seeds),
                                integrator=reference, spp=spp, **opts)
    return float(region_z(got, ref).max()), float(region_z(got, other).max())


def seeded_region_stats(scene, seeds, n=4, channel=None, **opts):
    """Per region of an n x n grid: the mean over independent renders (one per seed, the independent sampler, so
    that the renders are independent samples) and its standard error. Each render is reduced to its region
    means of one channel, or of the mean of the colour channels when channel is None."""
    import caustica

    def regions(img):
        img = np.asarray(img, np.float64)
        g = img[:, :, :3].mean(axis=2) if channel is None else img[:, :, channel]
        h, w = g.shape[0] // n, g.shape[1] // n
        return g[:h * n, :w * n].reshape(n, h, n, w).mean(axis=(1, 3))

    r = np.stack([regions(caustica.render(scene, seed=s, sampler="independent", **opts)) for s in seeds])
    return r.mean(axis=0), r.std(axis=0, ddof=1) / np.sqrt(len(seeds))


def region_z(a, b):
    """|difference| of two seeded_region_stats per region in units of its standard error."""
    (ma, sa), (mb, sb) = a, b
    return np.abs(ma - mb) / np.sqrt(sa ** 2 + sb ** 2 + 1e-12)


def white_sky_plate(material):
    """A large rectangle of `material` seen head-on through a narrow camera, under a white sky of radiance 1."""
    return {"camera": {"position": [0, 0, 10], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 3, "width": 16,
                       "height": 16},
            "materials": {"m": material},
            "shapes": [{"type": "rectangle", "material": "m", "transform": {"scale": 5}}],
            "lights": [{"type": "environment", "radiance": 1.0}]}


def relmse(x, ref):
    """Mean over pixels and channels of (x - r)^2 / (r^2 + 0.01) (shared/scenes/cornell-box.md)."""
    return float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01)))


@pytest.fixture
def caustica_bin():
    return BIN
