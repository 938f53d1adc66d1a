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


def relmse(x, ref):
    """Mean over pixels and channels of (x - r)^2 / (r^2 + 0.01) (shared/scenes/cornell-box.md)."""
    return float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01)))


@pytest.fixture
def caustica_bin():
    return BIN
