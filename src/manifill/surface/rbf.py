"""The thin-plate RBF on the positions: ``method="rbf"``, for fields that live in space, not on the surface.

The field is SciPy's thin-plate spline (:class:`scipy.interpolate.RBFInterpolator`,
``kernel="thin_plate_spline"``, ``degree=1``) through the samples' positions,
evaluated at every vertex: ``f(x) = sum_i c_i phi(|x - x_i|) + a + b.x`` with
``phi(r) = r^2 log r``. It ignores the mesh's connectivity, so it works across mesh
components and on digital surfaces (no triangles), and it is what a field defined in
space (a temperature in the air around a wing) looks like on the surface. Cross-validation
(:mod:`manifill.surface.crossval`) tells such fields from those that live on the
surface, where the mesh methods win.

The positions are centred on the mesh's bounding box and divided by a power of two
near its largest half-extent (so translating, or scaling by a power of two, changes
nothing; any scaling leaves the interpolant unchanged up to rounding), and the work is
done in the affine span of the vertices (a flat mesh is two-dimensional: a constant
coordinate would make the affine part singular) and, if the samples span less, in theirs.
The interpolant is exact at the samples and reproduces affine functions of the position
exactly.

``smoothing=lam`` makes the samples soft: the fit minimises
``sum_i w_i (f(x_i) - y_i)^2 + lam * c' K c`` (``K_ij = phi(|x_i - x_j|)``, the
spline's native-space seminorm: in two dimensions the bending energy
``int |D^2 f|^2`` divided by ``8 pi``), with positions in the normalised units above
and weights ``w_i`` (``sample_weights``, 1 by default); SciPy's ``smoothing`` is then
``lam / w_i`` per sample. ``lam -> 0`` interpolates, ``lam -> inf`` gives the weighted
least-squares affine fit.
"""

import math

import numpy as np

from ..deprecation import renamed
from ..errors import OptionError, SolveError
from ..memory import check_fits
from ..tolerances import TOL
from scipy.interpolate import RBFInterpolator

__all__ = ["thin_plate_rbf", "affine_frame"]

#: Public names renamed, kept one release with a warning (:mod:`manifill.deprecation`).
__getattr__ = renamed(__name__, {"thin_plate": "manifill.surface.rbf:thin_plate_rbf"})

#: Kernel-matrix entries evaluated at once (rows of vertices times samples): about 32 MB.
CHUNK_ENTRIES = 1 << 22


def affine_frame(V):
    """Centre, power-of-two scale and axes of the affine span of the positions ``V``.

    Parameters
    ----------
    V : (n, 3) numpy array
        Positions.

    Returns
    -------
    centre : (3,) numpy array
        The bounding box's centre.
    scale : float
        The power of two ``2**e`` with the largest half-extent ``h = m 2**e``, ``0.5 <= m < 1``
        (1.0 if all positions coincide).
    axes : (d, 3) numpy array or None
        Orthonormal directions spanning the positions (``d`` = 0, 1, 2), or None when
        they span all three dimensions (then no rotation is applied).

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> V, F = grid(4)
    >>> c, s, axes = affine_frame(V * 6.0 + 1.0)
    >>> s, axes.shape
    (4.0, (2, 3))
    """
    V = np.asarray(V, dtype=np.float64)
    lo, hi = V.min(axis=0), V.max(axis=0)
    centre = 0.5 * lo + 0.5 * hi
    h = float(np.max(0.5 * hi - 0.5 * lo))
    scale = math.ldexp(1.0, math.frexp(h)[1]) if h > 0 and np.isfinite(h) else 1.0
    P = (V - centre) / scale
    return (centre, scale) + (_span(P),)


def _span(P):
    """Orthonormal directions spanning the (centred) points ``P``, or None when they span all of them."""
    if len(P) < 2:
        return np.zeros((0, P.shape[1]))
    _, s, Wt = np.linalg.svd(P - P.mean(axis=0), full_matrices=False)
    keep = s > TOL.affine_span * s[0] if s[0] > 0 else np.zeros(len(s), dtype=bool)
    return None if keep.all() and len(s) == P.shape[1] else Wt[keep]


def thin_plate_rbf(V, X, vals, *, smoothing=None, sample_weights=None):
    """The thin-plate spline through values at positions ``X``, evaluated at ``V``.

    Parameters
    ----------
    V : (n, 3) numpy array
        Where to evaluate (the vertices; they also fix the frame, see the module's notes).
    X : (k, 3) numpy array
        The samples' positions, distinct.
    vals : (k, p) numpy array
        Their values, one column per field.
    smoothing : None or float >= 0, optional
        ``lam`` of the soft fit (see the module's notes); None or 0 interpolates.
    sample_weights : (k,) array_like of float > 0, optional
        The weights ``w_i`` of the soft fit (with ``smoothing``).

    Returns
    -------
    values : (n, p) numpy array
    report : dict
        ``kernel``, ``dims`` (of the space worked in), ``smoothing``, ``chunks``.

    Raises
    ------
    OptionError
        ``smoothing`` not a number >= 0; ``sample_weights`` without smoothing, or not positive.
    SolveError
        A singular system (two samples at one position, interpolated).
    ResourceError
        The dense system of ``k`` samples would not fit in memory.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(2)
    >>> idx = np.arange(0, 162, 9)
    >>> f = 1.0 + V[:, 0] - 2.0 * V[:, 2]
    >>> X, rep = thin_plate_rbf(V, V[idx], f[idx, None])
    >>> bool(np.allclose(X[:, 0], f)), rep["dims"]
    (True, 3)
    """

    vals = np.asarray(vals, dtype=np.float64)
    k, p = vals.shape
    lam = _smoothing(smoothing, sample_weights, k)
    check_fits(8.0 * 3 * (k + 4) ** 2 + 8.0 * CHUNK_ENTRIES * 2, f"the thin-plate system of {k:,} samples",
               "use fewer samples or a mesh method (e.g. method='biharmonic')")
    centre, scale, axes = affine_frame(V)
    Xs = (np.asarray(X, dtype=np.float64) - centre) / scale
    Vs = (V - centre) / scale
    if axes is not None:  # a flat (or straight) mesh: its own coordinates
        Xs, Vs = Xs @ axes.T, Vs @ axes.T
    sub = _span(Xs)
    if sub is not None:  # the samples span less (e.g. all on one line): the field is constant across
        mid = Xs.mean(axis=0)
        Xs, Vs = (Xs - mid) @ sub.T, (Vs - mid) @ sub.T
    dims = Xs.shape[1]
    report = {"kernel": "thin_plate_spline", "dims": int(dims), "smoothing": 0.0 if lam is None else float(lam),
              "scale": scale}
    if dims == 0:  # one sample (or all at one point): the constant that fits them best
        w = np.ones(k) if sample_weights is None else np.asarray(sample_weights, dtype=np.float64)
        report["chunks"] = 0
        return np.repeat((w @ vals / w.sum())[None, :], len(V), axis=0), report
    sm = 0.0 if lam is None else (lam if sample_weights is None else lam / np.asarray(sample_weights, float))
    try:
        rbf = RBFInterpolator(Xs, vals, kernel="thin_plate_spline", degree=1, smoothing=sm)
    except np.linalg.LinAlgError:
        raise SolveError(f"the thin-plate system of {k:,} samples is singular (two samples at one position?); "
                         f"weld coinciding vertices (clean_mesh, CLI --clean) or pass smoothing > 0") from None
    rows = max(1, CHUNK_ENTRIES // max(k, 1))
    out = np.empty((len(Vs), p))
    starts = range(0, len(Vs), rows)
    for a in starts:
        out[a:a + rows] = rbf(Vs[a:a + rows]).reshape(-1, p)
    report["chunks"] = len(starts)
    return out, report


def _smoothing(smoothing, sample_weights, k):
    """lambda as a float (None: interpolate), the weights checked."""
    if smoothing is None:
        if sample_weights is not None:
            raise OptionError("sample_weights weigh soft constraints; pass smoothing= too, or leave them out")
        return None
    if isinstance(smoothing, str):
        raise OptionError(f"smoothing={smoothing!r}: method='rbf' takes a number >= 0 ('auto' is for the mesh "
                          f"energies); pass a number")
    try:
        lam = float(smoothing)
    except (TypeError, ValueError):
        raise OptionError(f"smoothing={smoothing!r} is not a number >= 0; pass one") from None
    if not (lam >= 0 and np.isfinite(lam)):
        raise OptionError(f"smoothing={smoothing!r} is not a finite number >= 0; pass one")
    if sample_weights is not None:
        w = np.asarray(sample_weights, dtype=np.float64)
        if w.shape != (k,) or not (np.isfinite(w).all() and (w > 0).all()):
            raise OptionError(f"sample_weights must be {k} finite numbers > 0 (one per sample); got shape {w.shape}")
        if lam == 0:
            return None
    return lam if lam > 0 else None
