"""The biharmonic system beside the harmonic one, by every backend at hand: what a factorisation costs.

``python -m bench.biharmonic_backends [--levels 6,7,8] [--ks 100,1000] [--save FILE]``

For each icosphere level and sample count, the reduced system of the free vertices (samples
fixed) of the harmonic energy ``L`` and of the biharmonic energy ``L M^-1 L`` (cotangent ``L``,
Voronoi mass ``M``, as ``method='biharmonic'`` builds it) is factorised and solved once by:
SuperLU (SciPy, the pure-pip path), Pardiso (``[fast]``: symmetric positive definite), CHOLMOD
(scikit-sparse, when installed: a supernodal Cholesky, the sparse-solver benchmark's fastest), and
solved by AMG-preconditioned CG (pyamg, to the library's tolerance). The table gives set-up and
solve seconds and the factor's non-zeros, all in one process, one after the other. The public
sparse-solver benchmark (alecjacobson/sparse-solver-benchmark) factorises the biharmonic system of
a 720k-vertex dragon in 0.6 s with CHOLMOD supernodal on an Apple M4 and 5.7 s with MKL Pardiso on
a Xeon: the anchor for issue 25's "a biharmonic solve close to the harmonic one".
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from manifill.linalg.energies import polyharmonic_energy
from manifill.linalg.factorise import factorise
from manifill.mesh.laplacian import laplacian, mass_matrix
from manifill.mesh.shapes import icosphere


def reduced(A, idx):
    free = np.setdiff1d(np.arange(A.shape[0]), idx)
    A = sp.csr_matrix(A)
    return sp.csr_matrix(A[free][:, free]), sp.csr_matrix(A[free][:, idx])


def timed(f):
    t = time.perf_counter()
    out = f()
    return time.perf_counter() - t, out


def superlu(K, b):
    s, lu = timed(lambda: spla.splu(sp.csc_matrix(K), permc_spec="MMD_AT_PLUS_A"))
    t, x = timed(lambda: lu.solve(b))
    return s, t, x, lu.L.nnz + lu.U.nnz


def pardiso(K, b):
    s, (name, f) = timed(lambda: factorise(K, "pardiso", spd=True))
    if not name.startswith("pardiso"):
        return None
    t, x = timed(lambda: f.solve(b))
    return s, t, np.ravel(x), None


def cholmod(K, b):
    try:
        from sksparse.cholmod import cholesky
    except ImportError:
        return None
    s, f = timed(lambda: cholesky(sp.csc_matrix(K), ordering_method="default"))
    t, x = timed(lambda: f(b))
    return s, t, np.ravel(x), f.L().nnz


def amg(K, b):
    import pyamg

    s, ml = timed(lambda: pyamg.smoothed_aggregation_solver(K, symmetry="symmetric", max_coarse=500))
    M = ml.aspreconditioner(cycle="V")
    its = []
    t, (x, info) = timed(lambda: spla.cg(K, b, rtol=1e-10, maxiter=5000, M=M, callback=lambda _: its.append(1)))
    return s, t, x, f"{len(its)} its"


BACKENDS = {"superlu": superlu, "pardiso": pardiso, "cholmod": cholmod, "amg": amg}


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench.biharmonic_backends", description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="6,7")
    ap.add_argument("--ks", default="100,1000")
    ap.add_argument("--backends", default=",".join(BACKENDS))
    ap.add_argument("--max-superlu", type=int, default=200_000, help="skip SuperLU above this many unknowns")
    ap.add_argument("--save", default=None)
    args = ap.parse_args(argv)
    rows = []
    print("| vertices | k | energy | backend | set-up s | solve s | factor nnz or its | rel. residual |")
    print("|---|---|---|---|---|---|---|---|", flush=True)
    for level in map(int, args.levels.split(",")):
        V, F = icosphere(level)
        L = laplacian(V, F)
        M = mass_matrix(V, F, mass="voronoi")
        energies = {"harmonic": L, "biharmonic": polyharmonic_energy(L, M, 2)}
        for k in map(int, args.ks.split(",")):
            idx = np.sort(np.random.default_rng([level, k]).choice(len(V), k, replace=False))
            vals = np.sin(3 * V[idx, 0]) + V[idx, 2]
            for energy, A in energies.items():
                K, B = reduced(A, idx)
                b = -(B @ vals)
                for name in args.backends.split(","):
                    if name == "superlu" and K.shape[0] > args.max_superlu:
                        continue
                    got = BACKENDS[name](K, b)
                    if got is None:
                        continue
                    s, t, x, extra = got
                    res = float(np.linalg.norm(K @ x - b) / np.linalg.norm(b))
                    row = dict(vertices=len(V), k=k, energy=energy, backend=name, setup=s, solve=t,
                               extra=extra, residual=res)
                    rows.append(row)
                    print(f"| {len(V):,} | {k:,} | {energy} | {name} | {s:.2f} | {t:.3f} | {extra} | {res:.1e} |",
                          flush=True)
    if args.save:
        Path(args.save).write_text(json.dumps(rows, indent=1, default=str), encoding="utf-8")


if __name__ == "__main__":
    main()
