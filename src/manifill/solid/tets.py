"""Tetrahedral meshes of solids: the stiffness Laplacian, boundary faces, volumes, and tetgen.

The volume counterpart of :mod:`manifill.laplacian`: a solid ``(V, T)``, ``T`` an
``(m, 4)`` array of tetrahedra, has the same kind of Laplacian ``L = D - W``, so
:meth:`manifill.HarmonicSolver.from_laplacian` fills a solid as it fills a surface.

Which weights when
------------------
``cotan``
    The P1 finite-element stiffness matrix ``K_ij = integral grad phi_i . grad phi_j``:
    ``w_ij = sum over the tets on edge ij of l_kl cot(theta_kl) / 6``, with ``l_kl``
    the length of the opposite edge and ``theta_kl`` the dihedral angle there.
    Exact for linear functions on any tet mesh. Weights can be negative (obtuse
    dihedral angles), and then the maximum principle can fail.
``uniform``
    ``w_ij = 1`` on every tet edge: never negative, so the maximum principle holds;
    reproduces linear functions only on symmetric grids.

Unlike the 2D cotangent Laplacian, the 3D stiffness has units of length: scaling
``V`` by ``s`` scales ``L`` by ``s`` (the harmonic solution does not change).

Volumes and orientations are computed on the positions divided by
:func:`~manifill.validate.unit_scale` (a power of two, exact), so solids of size
``1e-150`` or ``1e150``, whose tet volumes underflow or overflow, are
tetrahedralised and oriented like unit ones.
"""

import numbers
import os
import subprocess
import sys
import tempfile

import numpy as np

from ..errors import MeshError, OptionError, ResourceError
from ..memory import check_fits
from ..mesh.topology import EdgeIndex, edges
from ..validate import as_cells, as_mesh, as_tets, bbox_diagonal, check_option, unit_scale

__all__ = ["tet_laplacian", "boundary_faces", "tet_volumes", "tetrahedralize", "surface_volume", "tet_count",
           "tetrahedralize_memory"]

WEIGHTS = ("cotan", "uniform")

#: The corner pairs of a tet's six edges, in the column order used below.
_PAIRS = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
#: The faces of a positively oriented tet, outward, each opposite the corner of its row.
_OUTWARD = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


def _volumes(V, T):
    """Signed volumes of validated arrays: positive when ``(b-a, c-a, d-a)`` is right-handed."""
    a = V[T[:, 0]]
    return np.einsum("ij,ij->i", np.cross(V[T[:, 1]] - a, V[T[:, 2]] - a), V[T[:, 3]] - a) / 6.0


def _negative(V, T):
    """Which tets of validated arrays are negatively oriented, at any scale (volumes of ``V / unit_scale(V)``)."""
    return _volumes(V / unit_scale(V), T) < 0


def tet_volumes(V, T):
    """Signed volume of every tetrahedron.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    T : (m, 4) array_like of int
        Tetrahedra ``(a, b, c, d)``.

    Returns
    -------
    (m,) numpy array
        ``det(b - a, c - a, d - a) / 6``: positive when ``d`` lies on the side of
        the triangle ``(a, b, c)`` that its right-hand normal points to.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> (tet_volumes(V, [[0, 1, 2, 3], [1, 0, 2, 3]]) * 6).tolist()
    [1.0, -1.0]
    """
    V, T = as_tets(V, T, allow_degenerate=True, allow_unreferenced=True)
    return _volumes(V, T)


def _edge_index(T, n):
    """The edges of the tets and, per tet, the edge id of its pairs 01, 02, 03, 12, 13, 23: ``(index, (m, 6))``.

    Three faces per tet cover its six edges, so :class:`~manifill.mesh.topology.EdgeIndex`
    of those triangles has exactly the tet edge graph.
    """
    m = len(T)
    index = EdgeIndex(np.concatenate([T[:, [0, 1, 2]], T[:, [0, 1, 3]], T[:, [0, 2, 3]]]), n)
    fe = index.face_edges  # column k: the edge opposite corner k of the triangle
    A, B, C = fe[:m], fe[m:2 * m], fe[2 * m:]
    return index, np.column_stack([A[:, 2], A[:, 1], B[:, 1], A[:, 0], B[:, 0], C[:, 0]])


def _stiffness_weights(V, T):
    """Off-diagonal weights ``w_ij = -K_ij`` of every tet, for the pairs 01, 02, 03, 12, 13, 23: (m, 6).

    With ``e_k = v_k - v_0`` the gradient of the barycentric coordinate of corner
    ``k`` is ``c_k / det`` (``c_1 = e_2 x e_3`` and cyclically, ``c_0 = -c_1 - c_2 - c_3``,
    ``det = e_1 . c_1``), so ``K_ij = |det| / 6 * c_i . c_j / det**2``.
    """
    a = V[T[:, 0]]
    e1, e2, e3 = V[T[:, 1]] - a, V[T[:, 2]] - a, V[T[:, 3]] - a
    c = [None, np.cross(e2, e3), np.cross(e3, e1), np.cross(e1, e2)]
    c[0] = -(c[1] + c[2] + c[3])
    six_vol = np.abs(np.einsum("ij,ij->i", e1, c[1])) * 6.0
    dots = np.column_stack([np.einsum("ij,ij->i", c[i], c[j]) for i, j in _PAIRS])
    return -np.divide(dots, six_vol[:, None], out=np.zeros_like(dots), where=six_vol[:, None] > 0)


def tet_laplacian(V, T, *, weights="cotan"):
    """Symmetric positive semi-definite Laplacian ``L = D - W`` of a tetrahedral mesh.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    T : (m, 4) array_like of int
        Tetrahedra, any integer dtype, either orientation.
    weights : {'cotan', 'uniform'}, optional
        ``cotan``: the P1 finite-element stiffness matrix (equal to
        ``-igl.cotmatrix(V, T)``); ``uniform``: 1 on every tet edge. See the
        module docstring for which one when.

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        ``L`` with sorted indices; its pattern is exactly the tet edge graph
        plus the diagonal (zero weights stay stored).

    Raises
    ------
    MeshError
        If ``(V, T)`` is malformed (see :func:`manifill.validate.as_tets`);
        zero-volume tets are accepted only with ``uniform`` weights.
    OptionError
        If ``weights`` is not one of the names above.

    Notes
    -----
    The weights are computed on positions centred and scaled to a unit
    bounding-box diagonal, then multiplied by that diagonal (the stiffness
    scales linearly with size), so a far origin costs no accuracy.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> L = tet_laplacian(V, [[0, 1, 2, 3]])
    >>> (6 * L.toarray()).round(12).tolist()
    [[3.0, -1.0, -1.0, -1.0], [-1.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 1.0]]
    >>> L.nnz  # the zero weights between corners 1, 2, 3 are stored
    16
    """
    check_option("weights", weights, WEIGHTS)
    V, T = as_tets(V, T, allow_degenerate=weights == "uniform", allow_unreferenced=True)
    index, ids = _edge_index(T, len(V))
    if weights == "uniform":
        w = np.ones(len(index))
    else:
        scale = bbox_diagonal(V)
        W = _stiffness_weights((V - V.mean(axis=0)) / scale, T)
        ok = ids >= 0  # a tet repeating a vertex has no edge there (and zero weight)
        w = np.bincount(ids[ok], weights=W[ok], minlength=len(index)) * scale
    return index.matrix(-w, diagonal=index.degree(w))


def _once(S):
    """Mask of the rows of ``S`` (sorted vertex triples) that occur exactly once."""
    n = int(S.max()) + 1
    if n < 2**20:  # pack the triple into one int64 key
        key = (S[:, 0] * n + S[:, 1]) * n + S[:, 2]
        order = np.argsort(key, kind="stable")
        step = key[order][1:] != key[order][:-1]
    else:
        order = np.lexsort(S.T[::-1])
        step = (S[order][1:] != S[order][:-1]).any(axis=1)
    single = np.r_[True, step] & np.r_[step, True]
    mask = np.zeros(len(S), dtype=bool)
    mask[order[single]] = True
    return mask


def boundary_faces(T, *, V=None):
    """The triangles on the boundary of a tetrahedral mesh, oriented outward.

    Parameters
    ----------
    T : (m, 4) array_like of int
        Tetrahedra.
    V : (n, 3) array_like, optional
        Vertex positions. With them, the faces of negatively oriented tets are
        flipped, so the result is outward for either orientation; without them
        every tet is taken as positively oriented (``tet_volumes > 0``, as
        :func:`tetrahedralize` returns them).

    Returns
    -------
    (f, 3) int64 numpy array
        The faces used by exactly one tet, in tet order, each with its normal
        (right-hand rule) pointing out of that tet, hence out of the solid.

    Raises
    ------
    MeshError
        If ``T`` (or ``(V, T)``) is malformed.

    Examples
    --------
    >>> boundary_faces([[0, 1, 2, 3]]).tolist()
    [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]
    >>> len(boundary_faces([[0, 1, 2, 3], [1, 2, 3, 4]]))  # the shared face is inside
    6
    """
    if V is None:
        try:
            n = max(int(np.max(T)) + 1, 1)
        except (TypeError, ValueError, OverflowError):
            n = 1  # as_cells names the problem
        T = as_cells(T, n, width=4, what="T", kind="tetrahedra")
        flip = np.zeros(len(T), dtype=bool)
    else:
        V, T = as_tets(V, T, allow_degenerate=True, allow_unreferenced=True)
        flip = _negative(V, T)
    faces = T[:, _OUTWARD]  # (m, 4, 3)
    faces[flip] = faces[flip][:, :, [0, 2, 1]]
    faces = faces.reshape(-1, 3)
    return np.ascontiguousarray(faces[_once(np.sort(faces, axis=1))])


# tetgen in a child process: on self-intersections it aborts the interpreter and writes "*_skipped" files
_CHILD = """
import sys
sys.path.insert(0, sys.argv[2])
import numpy as np
import tetgen
data = np.load("in.npz")
TV, TT = tetgen.TetGen(data["V"], data["F"].astype(np.int32)).tetrahedralize(switches=sys.argv[1])[:2]
np.savez("out.npz", TV=TV, TT=TT)
"""


def _failure(proc):
    """One line about why the tetgen child failed: tetgen's own error, the signal, or the last line."""
    lines = [s.strip() for s in (proc.stderr + "\n" + proc.stdout).splitlines() if s.strip()]
    said = [s[6:].strip().rstrip(".") for s in lines if s.startswith("Error:")] or proc.stderr.strip().splitlines()[-1:]
    return said[0][:200] if said else f"it stopped with exit code {proc.returncode}"


def surface_volume(V, F):
    """Volume enclosed by a closed triangle mesh (divergence theorem).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles, oriented consistently.

    Returns
    -------
    float
        ``|sum over triangles of a . (b x c)| / 6``: the volume for either
        orientation; exact for a closed surface (and independent of the origin).

    Raises
    ------
    MeshError
        If ``(V, F)`` is malformed.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> round(surface_volume(*icosphere(4)), 3)  # the ball's 4.189, less the chords
    4.18
    """
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    vol, s = unit_volume(V, F)
    return vol * s * s * s  # inf only when the volume itself overflows


def unit_volume(V, F):
    """``(vol, s)``: the volume enclosed by validated arrays is ``vol * s**3``, ``vol`` computed on ``V / s``.

    ``s`` is :func:`~manifill.validate.unit_scale` of ``V`` (1 for the usual
    sizes), so the triple products neither overflow nor underflow.
    """
    s = unit_scale(V)
    P = V / s
    P = P - P.mean(axis=0) if len(P) else P  # centred: no cancellation for a far origin
    return float(abs(np.einsum("ij,ij->i", P[F[:, 0]], np.cross(P[F[:, 1]], P[F[:, 2]])).sum()) / 6.0), s


#: Tets per ``volume / max_volume`` (tetgen makes them smaller than the bound: 1.45 measured with ``-q``),
#: tets per surface triangle for the surface alone (1.6-1.8 measured), and peak bytes per tet: the
#: child's tetgen mesh (about 160) or the parent's arrays and boundary check (360, measured).
_TETS_PER_BOUND, _TETS_PER_FACE, _TET_BYTES = 1.5, 2.0, 400


def _check_max_volume(max_volume):
    ok = isinstance(max_volume, numbers.Real) and not isinstance(max_volume, bool) and 0 < max_volume < np.inf
    if max_volume is not None and not ok:
        raise OptionError(f"max_volume={max_volume!r} is not a positive number; pass a volume in the units of V, "
                          f"or None for no limit (CLI --max-volume)")


def _tet_count(V, F, max_volume):
    """:func:`tet_count` on validated arrays, as a float (may exceed any int)."""
    surface = _TETS_PER_FACE * len(F)
    bound, s = _unit_bound(V, max_volume)
    if bound is None:
        return surface
    vol = unit_volume(V, F)[0]
    return _TETS_PER_BOUND * vol / bound + surface if bound > 0 else np.inf


def _unit_bound(V, max_volume):
    """``(bound, s)``: ``max_volume`` in units of ``s**3``, ``s`` the :func:`~manifill.validate.unit_scale` of ``V``.

    ``None`` without a bound, or when the bound is beyond any tet of the solid
    (it overflows in those units); 0 when it underflows (no tet is that small).
    """
    s = unit_scale(V)
    if max_volume is None:
        return None, s
    bound = float(max_volume) / s / s / s  # in three steps: s**3 itself overflows for s = 2**400
    return (None if bound == np.inf else bound), s


def tet_count(V, F, *, max_volume=None):
    """Estimated number of tets :func:`tetrahedralize` makes.

    About ``1.5 * volume / max_volume`` (tetgen's tets come out smaller than
    the bound) plus what the surface alone needs (about 2 per triangle), with
    the volume from :func:`surface_volume`.

    Parameters
    ----------
    V : (n, 3) array_like
    F : (m, 3) array_like of int
    max_volume : float, optional

    Returns
    -------
    int

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> tet_count(*icosphere(2), max_volume=1e-3)  # tetgen makes 5,578
    6710
    """
    _check_max_volume(max_volume)
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    return int(min(_tet_count(V, F, max_volume), 2.0**62))


def tetrahedralize_memory(V, F, *, max_volume=None):
    """Estimated peak memory of :func:`tetrahedralize`, in bytes.

    About 400 bytes per tet of :func:`tet_count` (tetgen's own mesh in its
    child process, then the arrays and checks here), plus the surface.

    Parameters
    ----------
    V : (n, 3) array_like
    F : (m, 3) array_like of int
    max_volume : float, optional

    Returns
    -------
    float

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> tetrahedralize_memory(*icosphere(2), max_volume=1e-9) > 1e12  # a trillion bytes
    True
    """
    _check_max_volume(max_volume)
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    return _TET_BYTES * _tet_count(V, F, max_volume) + 200.0 * len(F) + 1e6


def _tet_words(max_volume, tets):
    bound = "no max_volume" if max_volume is None else f"max_volume={float(max_volume):g}"
    count = f"~{tets:,.0f}" if tets < 1e15 else f"~{tets:.2g}" if tets < np.inf else "more than 1e308"
    return f"tetrahedralising with {bound} ({count} tets)"


def tetrahedralize(V, F, *, max_volume=None, quality=True):
    """A tetrahedral mesh of the solid bounded by a closed triangle mesh (tetgen).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions of the surface.
    F : (k, 3) array_like of int
        Triangles of a closed, manifold surface without self-intersections.
    max_volume : float, optional
        Volume bound in the units of ``V`` (tetgen ``-a``): interior points are
        added until the tets are about this small. A bound, not a guarantee:
        tets on the surface cannot be split (the surface is kept) and a few
        others may end up slightly larger. No bound by default.
    quality : bool, optional
        Add interior points until the tets are well shaped (tetgen ``-q``,
        radius-edge ratio 2); with False and no ``max_volume``, only the
        surface vertices are used.

    Returns
    -------
    TV : (N, 3) float64 numpy array
        Vertices: ``TV[:n]`` is ``V`` exactly, interior points follow.
    TT : (m, 4) int64 numpy array
        Tetrahedra, all positively oriented. The surface is preserved (tetgen
        ``-Y``, no points added on it): :func:`boundary_faces` of ``TT`` are the
        triangles ``F``.

    Raises
    ------
    ImportError
        Without the ``tetgen`` package.
    MeshError
        If ``(V, F)`` is malformed (see :func:`manifill.validate.as_mesh`), has
        boundary edges, or tetgen fails on it (e.g. self-intersections).
    OptionError
        If ``max_volume`` is not a positive number.
    ResourceError
        If the mesh is predicted not to fit in the memory available
        (:func:`tetrahedralize_memory`), or ``max_volume`` is so small next to
        the solid that the count of tets overflows; checked before tetgen starts.

    Notes
    -----
    tetgen runs in a child process in a temporary directory (a fraction of a
    second more per call): on bad input it can abort the interpreter and leave
    files in the working directory, and this way it can do neither.

    tetgen gets ``V / s`` and ``max_volume / s**3``, ``s`` the power of two of
    :func:`~manifill.validate.unit_scale` (1 for the usual sizes), and its
    points are multiplied back by ``s``: exact, so solids of size ``1e-150`` or
    ``1e150`` are meshed like unit ones and still keep their vertices bit for bit.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(2)
    >>> TV, TT = tetrahedralize(V, F)
    >>> bool((TV[:len(V)] == V).all()), len(boundary_faces(TT)) == len(F)
    (True, True)
    >>> round(float(tet_volumes(TV, TT).sum()), 2)  # the ball's 4.19, less the chords
    4.05
    """
    try:
        import tetgen
    except ImportError:
        raise ImportError("tetrahedralize needs the tetgen package: pip install 'manifill[volume]'") from None
    _check_max_volume(max_volume)
    V, F = as_mesh(V, F)
    _, count = edges(F)
    holes = int(np.count_nonzero(count == 1))
    if holes:
        raise MeshError(f"the surface has {holes} boundary edges, so it encloses no solid; close the holes "
                        f"(fill them with triangles) and try again")
    tets = _tet_count(V, F, max_volume)
    if tets == np.inf:  # a bound that is nothing next to the solid (1 for a solid of 1e150), whatever the memory
        raise ResourceError(f"{_tet_words(max_volume, tets)} needs more memory than any machine has; raise "
                            f"max_volume to a fraction of the solid's volume (CLI --max-volume)")
    check_fits(_TET_BYTES * tets + 200.0 * len(F) + 1e6, _tet_words(max_volume, tets),
               "raise max_volume (CLI --max-volume)")
    # p: the surface bounds the solid, Y: no points added on it, M: no merged facets (not quiet: its
    # error lines are the message)
    # tetgen works on V / s, s a power of two (1 for the usual sizes): exact, and of about unit size, where
    # its tolerances hold (at 1e-150 it finds every point collinear, at 1e150 it fails); the bound in units of s**3
    bound, s = _unit_bound(V, max_volume)
    switches = "pYM" + ("q" if quality else "") + ("" if bound is None else f"a{bound:.17g}")
    where = os.path.dirname(os.path.dirname(os.path.abspath(tetgen.__file__)))
    with tempfile.TemporaryDirectory(prefix="manifill-tetgen-") as tmp:
        np.savez(os.path.join(tmp, "in.npz"), V=V / s, F=F)
        proc = subprocess.run([sys.executable, "-c", _CHILD, switches, where],
                              cwd=tmp, capture_output=True, text=True, errors="replace", check=False)
        out = os.path.join(tmp, "out.npz")
        if proc.returncode != 0 or not os.path.exists(out):
            raise MeshError(f"tetgen could not tetrahedralize the surface ({_failure(proc)}); it must be closed, "
                            f"manifold and free of self-intersections: repair it and try again")
        with np.load(out) as data:
            TV, TT = data["TV"].astype(np.float64), data["TT"].astype(np.int64)
    n = len(V)
    neg = _volumes(TV, TT) < 0  # on the unit-size positions: the volumes of tets of 1e-150 underflow
    TV = TV * s  # exact: TV[:n] is V again when tetgen kept the surface vertices
    if len(TV) < n or not np.array_equal(TV[:n], V) or len(TT) == 0:
        raise MeshError("tetgen moved or dropped surface vertices; check the surface for self-intersections")
    TT[neg] = TT[neg][:, [0, 1, 3, 2]]
    got = np.sort(boundary_faces(TT), axis=1)
    want = np.sort(F, axis=1)
    if len(got) != len(want) or _once(np.concatenate([got, want])).any():
        raise MeshError("tetgen changed the surface triangles; check the surface for self-intersections "
                        "and nearly coplanar folds")
    return TV, TT
