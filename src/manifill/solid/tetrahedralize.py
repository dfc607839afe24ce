"""Step 7 for the tetrahedral form: a tetrahedral mesh of the solid bounded by a closed triangle mesh (TetGen).

:func:`tetrahedralize` runs TetGen in a child process with the surface kept,
:func:`tet_count` and :func:`tetrahedralize_memory` estimate its size before it
starts. The tetrahedral mesh's own arithmetic (volumes, the stiffness
Laplacian, boundary faces) is :mod:`manifill.solid.tets`.

TetGen gets the positions divided by :func:`~manifill.validate.unit_scale` (a
power of two, exact), so solids of size ``1e-150`` or ``1e150`` are meshed like
unit ones.
"""

import numbers
import os
import subprocess
import sys
import tempfile

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MeshError, OptionError, ResourceError
from ..memory import check_fits
from ..mesh.edges import edges
from ..mesh.tetmesh import negative_tets
from ..validate import as_mesh, unit_scale
from .tets import boundary_faces, rows_once, unit_volume

__all__ = ["tetrahedralize", "tet_count", "tetrahedralize_memory", "check_max_volume", "tet_count_on_mesh",
           "tet_words"]


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


#: Tets per ``volume / max_volume`` (tetgen makes them smaller than the bound: 1.45 measured with ``-q``),
#: tets per surface triangle for the surface alone (1.6-1.8 measured), and peak bytes per tet: the
#: child's tetgen mesh (about 160) or the parent's arrays and boundary check (360, measured).
_TETS_PER_BOUND, _TETS_PER_FACE, _TET_BYTES = 1.5, 2.0, 400


def check_max_volume(max_volume):
    """Refuse a ``max_volume`` that is not a positive finite number (None, no bound, passes).

    Parameters
    ----------
    max_volume : float or None
        A volume bound in the units of the surface's positions.

    Raises
    ------
    OptionError
        Zero, negative, infinite, NaN, a bool or not a number.

    Examples
    --------
    >>> check_max_volume(0.01)
    >>> check_max_volume(-1.0)
    Traceback (most recent call last):
    ...
    manifill.errors.OptionError: max_volume=-1.0 is not a positive number; pass a volume in the units of V, ...
    """
    ok = isinstance(max_volume, numbers.Real) and not isinstance(max_volume, bool) and 0 < max_volume < np.inf
    if max_volume is not None and not ok:
        raise OptionError(f"max_volume={max_volume!r} is not a positive number; pass a volume in the units of V, "
                          f"or None for no limit (CLI --max-volume)")


def tet_count_on_mesh(V, F, max_volume):
    """:func:`tet_count` on arrays :func:`manifill.validate.as_mesh` has returned, as a float.

    Parameters
    ----------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array
    max_volume : float or None
        Checked already (:func:`check_max_volume`).

    Returns
    -------
    float
        May exceed any int, and is ``inf`` when the bound underflows next to
        the solid (no memory holds that many tets).
    """
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
    the volume from :func:`manifill.solid.tets.surface_volume`.

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
    check_max_volume(max_volume)
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    return int(min(tet_count_on_mesh(V, F, max_volume), 2.0**62))


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
    check_max_volume(max_volume)
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    return _TET_BYTES * tet_count_on_mesh(V, F, max_volume) + 200.0 * len(F) + 1e6


def tet_words(max_volume, tets):
    """What a tetrahedralisation is, for messages: ``'tetrahedralising with max_volume=0.01 (~5,200 tets)'``.

    Parameters
    ----------
    max_volume : float or None
    tets : float
        The estimated count (:func:`tet_count_on_mesh`).

    Returns
    -------
    str

    Examples
    --------
    >>> tet_words(None, 160.0)
    'tetrahedralising with no max_volume (~160 tets)'
    """
    bound = "no max_volume" if max_volume is None else f"max_volume={float(max_volume):g}"
    count = f"~{tets:,.0f}" if tets < 1e15 else f"~{tets:.2g}" if tets < np.inf else "more than 1e308"
    return f"tetrahedralising with {bound} ({count} tets)"


def tetrahedralize(V: ArrayLike, F: ArrayLike, *, max_volume: float | None = None,
                   quality: bool = True) -> tuple[np.ndarray, np.ndarray]:
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
        ``-Y``, no points added on it): :func:`manifill.solid.tets.boundary_faces` of ``TT`` are the
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
    >>> from manifill.solid.tets import tet_volumes
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
    check_max_volume(max_volume)
    V, F = as_mesh(V, F)
    _, count = edges(F)
    holes = int(np.count_nonzero(count == 1))
    if holes:
        raise MeshError(f"the surface has {holes} boundary edges, so it encloses no solid; close the holes "
                        f"(fill them with triangles) and try again")
    tets = tet_count_on_mesh(V, F, max_volume)
    if tets == np.inf:  # a bound that is nothing next to the solid (1 for a solid of 1e150), whatever the memory
        raise ResourceError(f"{tet_words(max_volume, tets)} needs more memory than any machine has; raise "
                            f"max_volume to a fraction of the solid's volume (CLI --max-volume)")
    check_fits(_TET_BYTES * tets + 200.0 * len(F) + 1e6, tet_words(max_volume, tets),
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
    neg = negative_tets(TV, TT)  # on the unit-size positions: the volumes of tets of 1e-150 underflow
    TV = TV * s  # exact: TV[:n] is V again when tetgen kept the surface vertices
    if len(TV) < n or not np.array_equal(TV[:n], V) or len(TT) == 0:
        raise MeshError("tetgen moved or dropped surface vertices; check the surface for self-intersections")
    TT[neg] = TT[neg][:, [0, 1, 3, 2]]
    got = np.sort(boundary_faces(TT), axis=1)
    want = np.sort(F, axis=1)
    if len(got) != len(want) or rows_once(np.concatenate([got, want])).any():
        raise MeshError("tetgen changed the surface triangles; check the surface for self-intersections "
                        "and nearly coplanar folds")
    return TV, TT
