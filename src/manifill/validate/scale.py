"""Scale: the power of two that brings positions to unit size, and the bounding-box diagonal.

Every computation on positions divides them by :func:`unit_scale` (exact) before
forming products, so meshes in nanometres or in light years give the results of
unit-size ones.
"""

import math

import numpy as np

from ..errors import MeshError

__all__ = ["UNIT_WINDOW", "scale_of", "unit_scale", "scale_and_diagonal", "bbox_diagonal", "check_size",
           "FLOAT_DECADES", "LOW_DECADES"]

#: Positions whose largest bounding-box half-extent has a binary exponent within
#: ``-UNIT_WINDOW .. UNIT_WINDOW`` (about 2e-10 to 4e9) are used as they are: products of
#: such coordinates neither overflow nor underflow, and the results stay bit for bit.
UNIT_WINDOW = 32


def _half_extents(V):
    """Half the bounding-box extent of ``V`` along every axis, as floats (no overflow)."""
    # column by column: a strided reduction per column is ~10x faster than axis=0 on (n, 3)
    return [0.5 * float(V[:, k].max()) - 0.5 * float(V[:, k].min()) for k in range(V.shape[1])]


def scale_of(h):
    """The power of two ``2**e`` with ``h = m 2**e``, ``0.5 <= m < 1``; 1.0 inside the window or for ``h = 0``.

    Examples
    --------
    >>> scale_of(3.0), scale_of(0.0), scale_of(1e100) == 2.0**333
    (1.0, 1.0, True)
    """
    if not (h > 0 and np.isfinite(h)):
        return 1.0
    e = math.frexp(h)[1]
    if -UNIT_WINDOW <= e <= UNIT_WINDOW:
        return 1.0
    return math.ldexp(1.0, min(max(e, -1020), 1020))


def unit_scale(V):
    """A power of two ``s`` that brings the positions ``V / s`` to about unit size.

    Dividing by a power of two is exact, so lengths, areas and volumes computed on
    ``V / s`` and multiplied back by ``s``, ``s**2``, ``s**3`` equal the ones computed
    on ``V`` wherever the latter do not overflow or underflow, and angles, cotangent
    weights and normals are unchanged. Meshes in metres at the size of a planet or in
    nanometres thus work like unit ones.

    Parameters
    ----------
    V : (n, d) numpy array
        Points (or difference vectors).

    Returns
    -------
    float
        ``1.0`` when the largest half-extent of the bounding box has a binary exponent
        within ``-UNIT_WINDOW .. UNIT_WINDOW`` (then ``V`` is used as it is); otherwise
        the power of two that brings it into ``[0.5, 1)``. If all points coincide,
        their largest absolute coordinate decides instead.

    Examples
    --------
    >>> unit_scale(np.array([[0.0, 0, 0], [1e150, 0, 0]])) == 2.0**498
    True
    >>> unit_scale(np.array([[0.0, 0, 0], [1e6, 0, 0]]))
    1.0
    """
    V = np.asarray(V, dtype=np.float64)
    if V.size == 0:
        return 1.0
    V = V.reshape(len(V), -1)
    h = max(_half_extents(V))
    if not h > 0:
        h = max(float(np.abs(V[:, k]).max()) for k in range(V.shape[1]))
    return scale_of(h)


def scale_and_diagonal(V):
    """``(s, diag)``: :func:`unit_scale` of ``V`` and its bounding-box diagonal in units of ``s``.

    Examples
    --------
    >>> scale_and_diagonal(np.array([[0.0, 0, 0], [3, 4, 0]]))
    (1.0, 5.0)
    """
    if len(V) == 0:
        return 1.0, 1.0
    h = _half_extents(V)
    s = scale_of(max(h))
    inv = 1.0 / s
    # (2 h)**2 summed as in the plain formula, on extents of about unit size
    d = float(np.sqrt(sum((2.0 * x * inv) ** 2 for x in h)))
    if not d > 0:
        return unit_scale(V), 0.0
    return s, d


def bbox_diagonal(V):
    """Length of the diagonal of the axis-aligned bounding box of ``V``.

    Parameters
    ----------
    V : (n, d) numpy array
        Points.

    Returns
    -------
    float
        The diagonal length (computed on extents of about unit size, so it neither
        overflows nor underflows where the length itself is a float); 1.0 if ``V``
        is empty or all points coincide.

    Examples
    --------
    >>> round(bbox_diagonal(np.array([[0.0, 0, 0], [3e200, 4e200, 0]])) / 1e200, 12)
    5.0
    """
    s, d = scale_and_diagonal(V)
    return d * s if d > 0 else 1.0


#: Decimal exponents a computed quantity may reach (float64 holds about 1e-308 to 1e308; kept off the edge).
FLOAT_DECADES = 306
#: ... for a power of the areas multiplied with others (the triharmonic energy, the gp's precision): a vertex's
#: area is the size squared over the vertex count, the Laplacian's weights reach 1e4 (measured: the triharmonic
#: energy of a 642-vertex sphere overflows at 1e-76 units, 1e-302 by the size alone).
LOW_DECADES = 280


def check_size(V, power, what, quantity, fix, decades=FLOAT_DECADES):
    """Refuse positions whose size to ``power`` (areas: 2; the triharmonic energy's squared areas: 4) leaves
    floating point, with one line naming the size, the quantity and the fix. ``decades`` is the largest decimal
    exponent allowed (less than 306 where the quantity is one factor among others, as a vertex's share of the
    area is smaller than the size squared).

    Raises
    ------
    MeshError

    Examples
    --------
    >>> check_size(np.array([[0.0, 0, 0], [1e100, 0, 0]]), 2, "the cloud", "areas", "rescale it")
    >>> check_size(np.array([[0.0, 0, 0], [1e200, 0, 0]]), 2, "the cloud", "areas", "rescale it")
    Traceback (most recent call last):
    ...
    manifill.errors.MeshError: the cloud is 1e+200 units across: its areas would be about 1e+400, beyond ...
    """
    V = np.asarray(V, dtype=np.float64).reshape(len(V), -1)
    if V.size == 0:
        return
    h = 2.0 * max(_half_extents(V))
    if not (h > 0 and np.isfinite(h)):
        return
    exponent = math.log10(h) * power
    if abs(exponent) > decades:
        raise MeshError(f"{what} is {h:.3g} units across: its {quantity} would be about 1e{round(exponent):+d}, "
                        f"beyond floating point; {fix}")
