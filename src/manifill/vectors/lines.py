"""Line fields from arrows whose sign is unknown: orient the arrows when that predicts them better.

A line field (``symmetry=2``) in the power representation (:mod:`manifill.vectors.fill`) doubles every angle, so
it turns twice as fast as the arrows it came from and its fill is rougher: measured on a sphere, 4-13 times the
direction error of the fill of the correctly signed arrows. When the lines are the directions of an arrow field
whose signs were lost (wind vanes, flow seen without its sense), choosing the signs back is better:
:func:`orient` picks the signs ``s`` whose arrow fill has the least energy, ``min_s (s w)^H K (s w)`` with ``K``
the energy of the fill as a form of the samples (the Schur complement of the fixed vertices: one solve per
sample), by the spectral relaxation (the eigenvectors of the least eigenvalues), random roundings of them and
single flips while one lowers the energy.

Lines that no arrow field gives (fibres turning around a point by half a turn) have no such signs. Which way
fits the data is measured on the data: the leave-one-out prediction of every sample's line from the others,
exact and free from ``K`` (``z_i = -K_ii^-1 sum_j K_ij z_j``, the minimum-energy fill without sample ``i``), for
the oriented arrows and for the power representation; the one that predicts the held-out lines better is filled.
Both need ``K``: with more than :data:`ORIENT_MAX` vertex-samples products, or samples inside faces, the power
representation alone runs (``report['lines']`` says so).
"""

import numpy as np

from .fill import VectorFill

__all__ = ["ORIENT_MAX", "LineFill", "orient", "loo_angles"]

#: The largest ``vertices x samples`` for which the samples' energy form is built (``K``: one solve per sample).
ORIENT_MAX = 60_000_000


def _schur(fill):
    """``K``: the energy of the fill as a form of the samples' complex values (``k x k``, Hermitian)."""
    k = len(fill.vertices)
    Z = fill.complex.solve(np.eye(k, dtype=np.complex128))
    return Z.conj().T @ (fill.energy @ Z)


def _greedy(R, s):
    """Single flips while one lowers ``s' R s``."""
    diag = np.diag(R)
    for _ in range(20 * len(s)):
        gain = 4.0 * s * (R @ s) - 4.0 * diag  # the energy a flip removes
        i = int(np.argmax(gain))
        if gain[i] <= 1e-12 * abs(float(s @ R @ s)):
            break
        s[i] = -s[i]
    return s


def orient(R, seed=0, trials=64):
    """The signs ``s`` (``+1``/``-1``) that make ``s' R s`` least (``R`` real symmetric ``k x k``).

    Examples
    --------
    >>> R = np.array([[1.0, -0.9, 0.0], [-0.9, 1.0, 0.8], [0.0, 0.8, 1.0]])
    >>> s = orient(R)
    >>> (s * s[0]).tolist()
    [1.0, 1.0, -1.0]
    """
    k = len(R)
    if k == 1:
        return np.ones(1)
    _, vec = np.linalg.eigh(R)
    low = vec[:, :min(8, k)]
    rng = np.random.default_rng(seed)
    best, best_e = None, np.inf
    for c in [low[:, 0]] + [low @ rng.standard_normal(low.shape[1]) for _ in range(trials)]:
        s = np.where(c >= 0, 1.0, -1.0)
        s = _greedy(R, s)
        e = float(s @ R @ s)
        if e < best_e - 1e-12 * abs(e):
            best, best_e = s, e
    return best


def loo_angles(K, Z, symmetry):
    """Each sample's line (or arrow) against its leave-one-out prediction from the others: angles in radians.

    ``Z`` holds the samples' complex values in the representation ``K`` is the energy of (``symmetry`` turns a
    difference of their angles into one of the lines').
    """
    d = np.real(np.diag(K))
    pred = -(K @ Z - d * Z) / d
    return np.abs(np.angle(pred * np.conj(Z))) / symmetry


class LineFill:
    """Line fields (``symmetry=2``) from arrows of unknown sign: oriented arrows or the power representation,
    whichever predicts the held-out samples better (see the module's description).

    Parameters
    ----------
    V, F, idx
        As :class:`~manifill.vectors.fill.VectorFill`.
    **keywords
        ``method``, ``solver``, ``max_distance``, ``validated``: as :class:`~manifill.vectors.fill.VectorFill`.
    """

    def __init__(self, V, F, idx, **keywords):
        self.lines = VectorFill(V, F, idx, symmetry=2, **keywords)
        self.connection, self.V, self.points = self.lines.connection, self.lines.V, self.lines.points
        n, k = self.connection.n, self.lines.k
        self.why = None
        if self.lines.complex is None:
            self.why = "samples inside faces, smoothing or an iterative solver: the power representation alone"
        elif n * k > ORIENT_MAX:
            self.why = f"{n:,} vertices x {k:,} samples is beyond the orientation's budget ({ORIENT_MAX:,})"
        self.arrows = None
        if self.why is None:
            self.arrows = VectorFill(self.V, F, idx, symmetry=1, like=self.lines,
                                     **{k: v for k, v in keywords.items() if k in ("method", "solver")})
            self.K1, self.K2 = _schur(self.arrows), _schur(self.lines)

    def solve(self, vectors, *, normal="refuse"):
        """The line field(s) for arrows ``(k, 3[, p])``: complex vertex values in the power representation and a
        report (``report['lines']``: oriented or not per field, the leave-one-out errors in degrees)."""
        Zp, report = self.lines.solve(vectors, normal=normal)
        if self.arrows is None:
            report["lines"] = {"oriented": False, "why": self.why}
            return Zp, report
        W1 = self.arrows.sample_coordinates(vectors, normal)
        W2 = self.lines.sample_coordinates(vectors, normal)
        one = W1.ndim == 1
        W1, W2, Zp = (W1[:, None], W2[:, None], Zp[:, None]) if one else (W1, W2, Zp)
        out, info = Zp.copy(), []
        for j in range(W1.shape[1]):
            R = np.real(np.conj(W1[:, j])[:, None] * self.K1 * W1[None, :, j])
            s = orient(R)
            e_arrows = float(np.degrees(np.mean(loo_angles(self.K1, s * W1[:, j], 1) % np.pi)))
            e_lines = float(np.degrees(np.mean(loo_angles(self.K2, W2[:, j], 2))))
            use = e_arrows < e_lines
            if use:
                X = np.asarray(vectors, dtype=np.float64)
                X = X if one else X[..., j]
                Z1, _ = self.arrows.solve(X * s[:, None], normal=normal)
                out[:, j] = np.abs(Z1) * np.exp(2j * np.angle(Z1))  # the oriented arrows' lines, as powers
            info.append({"oriented": use, "loo_degrees_oriented": e_arrows, "loo_degrees_lines": e_lines})
        report["lines"] = info[0] if one else info
        return (out[:, 0] if one else out), report

    def representative(self, Z):
        """One vector per line: ``|Z| exp(1j arg Z / 2)``."""
        return self.lines.representative(Z)
