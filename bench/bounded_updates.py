"""The bounded biharmonic's active set replayed on one cached factor: what a factorisation per face costs.

``python -m bench.bounded_updates [--level 6] [--k 100] [--field globe|smooth]``

Runs the library's bounded biharmonic (``bounds='samples'``: an active-set loop that sets its
backend up anew for every face) and records the faces it visits; then replays the same faces on
one CHOLMOD factorisation of the free system (scikit-sparse, optional), each face by a rank update
or downdate of the factor (the indices that joined or left the face, held at their bound by a
penalty ``w``) and one solve. The replay is exact up to the penalty (its error is printed); it
measures what issue 25's "reuse one factorisation across active-set changes" can save, not a
finished solver. Needs ``pip install scikit-sparse`` against the system's SuiteSparse (Debian:
``libsuitesparse-dev``; with ``libopenblas0-pthread`` installed its supernodal factor is about 2x
faster than with the reference BLAS).
"""

import argparse
import time

import numpy as np
import scipy.sparse as sp

import manifill.linalg.faces as faces_mod
from manifill.linalg.quadratic import QuadraticSolver
from manifill.surface.energy_fill import _energy
from manifill.surface.surface import Surface

from .fields import smooth_field
from .fields_more import globe_case


def record_faces(A, idx, vals):
    """The bounded answer of the library's loop, its time, and the faces (``side`` vectors) it solved."""
    faces, solve = [], faces_mod.Faces.solve

    def spy(self, side, x0, beq=None):
        faces.append(side.copy())
        return solve(self, side, x0, beq)

    faces_mod.Faces.solve = spy
    try:
        q = QuadraticSolver(A, idx, solver="direct", symmetric_pattern=True)
        t = time.perf_counter()
        x = q.solve(vals, lo=vals.min(), hi=vals.max())
        return x, time.perf_counter() - t, faces
    finally:
        faces_mod.Faces.solve = solve


def replay(K, b, faces, lo, hi, weight=1e10):
    """The faces solved on one CHOLMOD factor of ``K`` by rank updates: ``(x, seconds by part)``."""
    from sksparse.cholmod import cholesky

    t = time.perf_counter()
    factor = cholesky(sp.csc_matrix(K))
    seconds = {"factor": time.perf_counter() - t, "updates": 0.0, "solves": 0.0}
    w = weight * K.diagonal().max()
    cur = np.zeros(K.shape[0], np.int8)
    x = None
    for side in faces:
        t = time.perf_counter()
        for cols, down in ((np.flatnonzero((cur == 0) & (side != 0)), False),
                           (np.flatnonzero((cur != 0) & (side == 0)), True)):
            if cols.size:
                C = sp.csc_matrix((np.full(cols.size, np.sqrt(w)), (cols, np.arange(cols.size))),
                                  shape=(K.shape[0], cols.size))
                factor.update_inplace(C, subtract=down)
        seconds["updates"] += time.perf_counter() - t
        t = time.perf_counter()
        cur = side.copy()
        rhs = b.copy()
        at = np.flatnonzero(side)
        rhs[at] += w * np.where(side[at] > 0, hi, lo)
        x = factor(rhs)
        seconds["solves"] += time.perf_counter() - t
    return x, seconds


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench.bounded_updates", description=__doc__.splitlines()[0])
    ap.add_argument("--level", type=int, default=6)
    ap.add_argument("--k", type=int, default=100)
    ap.add_argument("--field", choices=("globe", "smooth"), default="globe")
    args = ap.parse_args(argv)
    case = globe_case(args.level)
    V, F = case.V, case.F
    f = case.truth if args.field == "globe" else smooth_field(V)
    idx = np.sort(np.random.default_rng([0, args.k]).choice(len(V), args.k, replace=False))
    vals = f[idx]
    s = Surface.from_mesh(V, F)
    A = sp.csr_matrix(_energy(s, s.laplacian("cotan"), 2))
    xb, seconds, faces = record_faces(A, idx, vals)
    print(f"{len(V):,} vertices, {args.k} samples, {args.field}: the library's loop {seconds:.2f} s over "
          f"{len(faces)} faces ({int((faces[-1] != 0).sum()) if faces else 0} indices at a bound at the end)")
    free = np.setdiff1d(np.arange(len(V)), idx)
    K = sp.csr_matrix(A[free][:, free])
    try:
        x, parts = replay(K, -(A[free][:, idx] @ vals), faces, vals.min(), vals.max())
    except ImportError:
        print("scikit-sparse is not installed: no replay")
        return
    full = np.zeros(len(V))
    full[idx], full[free] = vals, x
    total = sum(parts.values())
    print(f"replayed on one CHOLMOD factor: {total:.2f} s (factor {parts['factor']:.2f}, updates "
          f"{parts['updates']:.2f}, solves {parts['solves']:.2f}); {seconds / total:.1f}x faster; largest "
          f"difference {np.abs(full - xb).max() / np.ptp(vals):.1e} of the range (the penalty's)")


if __name__ == "__main__":
    main()
