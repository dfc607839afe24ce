"""The Dirichlet reduction of :class:`manifill.linalg.quadratic.QuadraticSolver`: the components of ``A``'s graph
that no fixed index (nor equality row) anchors, and the split of ``A``'s unknown rows into ``A_II`` and ``A_Ib``.
"""

import numpy as np
import scipy.sparse as sp

from ..errors import SolveError
from ..mesh.topology import pattern_components

__all__ = ["unanchored", "split_rows"]


def unanchored(A, idx, Aeq, on_empty, symmetric_pattern):
    """The components of ``A``'s graph without a fixed index ``idx`` or a row of ``Aeq``.

    Returns ``(ncomp, empty, empty_components)``: the number of components, the (n,) bool mask of the indices in
    components without an anchor (none with ``on_empty='solve'``) and those components as ``{"vertices",
    "example_vertex"}``, largest first; raises :class:`~manifill.errors.SolveError` naming the largest with
    ``on_empty='error'``.
    """
    ncomp, labels = pattern_components(A, symmetric=symmetric_pattern)
    anchors = labels[idx]
    if Aeq is not None:  # a row anchors every component it touches
        anchors = np.concatenate([anchors, labels[Aeq.indices[Aeq.data != 0]]])
    has_fixed = np.bincount(anchors, minlength=ncomp) > 0
    empty = ~has_fixed[labels]
    if on_empty == "solve":  # a positive definite energy: such components have a unique minimiser too
        has_fixed[:] = True
        empty[:] = False
    empty_components = []
    if empty.any():
        for c in np.flatnonzero(~has_fixed):
            members = np.flatnonzero(labels == c)
            empty_components.append({"vertices": int(members.size), "example_vertex": int(members[0])})
        empty_components.sort(key=lambda e: -e["vertices"])
        if on_empty == "error":
            e = empty_components[0]
            more = f" (and {len(empty_components) - 1} more)" if len(empty_components) > 1 else ""
            raise SolveError(
                f"a connected component of {e['vertices']} vertices (e.g. vertex {e['example_vertex']}) "
                f"has no fixed vertex{more}, so its values are undetermined; add a sample there, "
                f"or pass on_empty='nan' (CLI: --on-empty nan) to leave it NaN"
            )
    return ncomp, empty, empty_components


def split_rows(A, unknown, idx):
    """``(A_II, A_Ib)``: the rows of ``A`` at ``unknown``, with their columns at ``unknown`` and at ``idx`` (in order).

    Sorted column indices stay sorted in ``A_II``; ``A_Ib``'s are in the order of ``idx``.
    """
    n = A.shape[0]
    # A_II and A_Ib in one pass over the unknowns' rows, columns renumbered by one map: unknown j -> its
    # number, fixed j -> -2 - its place in idx, empty j -> -1; rows keep their order, so sorted stays sorted
    N, k = unknown.size, idx.size
    it = np.int32 if max(A.nnz, n) < 2**31 - 1 else np.int64
    code = np.full(n, -1, dtype=it)
    code[unknown] = np.arange(N, dtype=it)
    code[idx] = -2 - np.arange(k, dtype=it)
    starts = A.indptr[unknown]
    lens = (A.indptr[unknown + 1] - starts).astype(it, copy=False)
    row_ptr = np.zeros(N + 1, dtype=np.int64)
    np.cumsum(lens, out=row_ptr[1:])
    at = slice(None) if N == n else (  # the unknown rows' entries, row after row
        np.repeat((starts - row_ptr[:-1]).astype(it), lens) + np.arange(row_ptr[-1], dtype=it))
    c, data = code[A.indices[at]], A.data[at]
    del at, code
    parts = []
    for inner, keep in ((True, c >= 0), (False, c <= -2)):
        counted = np.zeros(c.size + 1, dtype=it)
        np.cumsum(keep, out=counted[1:])
        ptr = counted[row_ptr]
        del counted
        cols = c[keep] if inner else -2 - c[keep]
        part = sp.csr_array((data[keep], cols, ptr), shape=(N, N if inner else k))
        part.has_sorted_indices = bool(A.has_sorted_indices) and inner
        parts.append(part)
    del c, data
    return tuple(parts)
