import os
import sys

import numpy as np
import pytest

# The command line: the one installed beside this Python, or CAUSTICA_BIN (the GPU bundle's wrapper).
BIN = os.environ.get("CAUSTICA_BIN") or os.path.join(os.path.dirname(sys.executable), "caustica")


def mean_and_se(values):
    """Mean and standard error of independent estimates."""
    v = np.asarray(values, dtype=np.float64).ravel()
    return v.mean(), v.std(ddof=1) / np.sqrt(v.size)


def relmse(x, ref):
    """Mean over pixels and channels of (x - r)^2 / (r^2 + 0.01) (shared/scenes/cornell-box.md)."""
    return float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01)))


@pytest.fixture
def caustica_bin():
    return BIN
