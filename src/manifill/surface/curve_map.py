"""Step 4's linear curve values as one sparse map from the sample values, for many fields at once.

The ``hermite`` and ``linear`` curve values of :mod:`manifill.surface.curve_values` are
linear in the sample values: on a fixed partition, ``bc = C @ vals`` for a sparse
``C`` (curve vertices x samples), whose column ``j`` is Step 4 applied to the ``j``-th
unit vector. :func:`curve_map` builds ``C`` that way, a block of columns at a time, so
that a prepared reconstruction (:class:`manifill.Reconstructor`) pays Step 4 once, and
:meth:`manifill.Reconstructor.matrix` composes it with the fill.
"""

import numpy as np
import scipy.sparse as sp

from .curve_values import values_on_curves

__all__ = ["LINEAR_CURVE_VALUES", "curve_map"]

#: The curve values that are linear in the sample values.
LINEAR_CURVE_VALUES = ("hermite", "linear")

#: Unit columns evaluated at once while building the map.
BLOCK = 256


def curve_map(surface, part, idx, method="hermite"):
    """``(b, C)``: the curve vertices and the sparse map with ``values_on_curves(...).vals == C @ vals``.

    Parameters
    ----------
    surface : Surface
    part : Partition
        Steps 2-3 through ``idx``.
    idx : (k,) int64 numpy array
        Sample vertices, sorted and unique.
    method : {'hermite', 'linear'}, optional
        Step 4's curve values (:data:`LINEAR_CURVE_VALUES`).

    Returns
    -------
    b : (c,) int64 numpy array
        The curve vertices, sorted.
    C : (c, k) scipy.sparse.csr_array
        Exact zeros dropped.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> from manifill.surface.partition import partition
    >>> from manifill.surface.surface import Surface
    >>> V, F = icosphere(2)
    >>> s, idx = Surface.from_mesh(V, F), np.array([0, 10, 50, 90, 120])
    >>> b, C = curve_map(s, partition(s, idx), idx)
    >>> vals = V[idx, :1]
    >>> bool(np.allclose(C @ vals, values_on_curves(s, partition(s, idx), idx, vals).vals))
    True
    """
    k = idx.size
    blocks, b = [], None
    for start in range(0, k, BLOCK):
        E = np.zeros((k, min(BLOCK, k - start)))
        E[np.arange(start, start + E.shape[1]), np.arange(E.shape[1])] = 1.0
        b, block = values_on_curves(surface, part, idx, E, method=method)
        blocks.append(sp.csr_array(block))
    C = sp.csr_array(sp.hstack(blocks, format="csr")) if blocks else sp.csr_array((0, 0))
    C.eliminate_zeros()
    return b, C
