"""Solids shared by the tests of the voxel and tetrahedral fills and of Steps 1-8 on a solid."""

import functools
import importlib.util

import numpy as np
import pytest

from manifill.mesh.shapes import icosphere
from manifill.solid.tetrahedralize import tetrahedralize

CONNECTIVITIES = (6, 18, 26)
SPACINGS = [(1.0, 1.0, 1.0), (1.0, 1.0, 2.5), (0.5, 1.0, 3.0)]
HAVE_TETGEN = importlib.util.find_spec("tetgen") is not None
needs_tetgen = pytest.mark.skipif(not HAVE_TETGEN, reason="tetgen is not installed")


def coords(shape, spacing, origin=(0.0, 0.0, 0.0)):
    """Physical position of every voxel, shaped (n0, n1, n2, 3)."""
    return np.moveaxis(np.indices(shape), 0, -1) * np.asarray(spacing, float) + np.asarray(origin, float)


def ball(spacing, size=14.0, radius=6.2):
    """A ball of the given physical radius on a grid of about ``size`` per side."""
    h = np.asarray(spacing, float)
    shape = tuple(int(np.ceil(size / x)) + 1 for x in h)
    X = coords(shape, h)
    centre = (np.array(shape) - 1) * h / 2
    return np.linalg.norm(X - centre, axis=-1) < radius


def one_line(info):
    msg = str(info.value)
    assert msg and "\n" not in msg
    return msg


@functools.lru_cache(maxsize=None)
def _tet_ball(k):
    return tetrahedralize(*icosphere(k))


def tet_ball(k=2):
    TV, TT = _tet_ball(k)
    return TV.copy(), TT.copy()
