"""``method='gp'`` beside GeometricKernels' Matérn kernel on a mesh, side by side in one run.

``python -m bench.gp_peers [--levels 5,6,7] [--k 100] [--num default] [--save FILE]``

On icospheres (level 5: 10,242 vertices, 6: 40,962, 7: 163,842), two fields: a draw of
manifill's Matérn prior (range 0.5, sigma 1, mean 2; :mod:`bench.gp_common`) and the smooth
``sin(2x) + yz + 0.5 cos(3y)``; ``k`` random sample vertices (seed ``(0, k)``).

- manifill: ``reconstruct(V, F, idx, vals, method='gp')`` with its defaults (range, sigma
  fitted by the restricted likelihood; mean and std at every vertex).
- GeometricKernels (numpy backend): ``geometric_kernels.spaces.Mesh(V, F)`` and
  ``MaternGeometricKernel(space)`` with the library's default number of eigenpairs
  (``--num default``: ``min(1000, n)``), ``nu = 1`` (manifill's ``alpha = 2`` on a surface);
  the kernel is normalised by the library (unit mean variance). Fit: a constant mean by
  generalised least squares and the variance in closed form (both profiled out of the
  Gaussian likelihood of the ``k`` samples), the lengthscale by maximising the profiled
  likelihood (scipy's bounded scalar search over log lengthscale), a jitter of
  ``1e-6`` times the variance on the diagonal; predicted mean and std (kriging: plus the
  mean's estimation variance, as manifill does) at every vertex.

Reported per (mesh, field) and tool: rel. RMSE (off the samples, / range of the truth),
coverage of the 90 % interval, mean NLPD, fitted range (GeometricKernels:
``sqrt(8 nu) * lengthscale``), seconds (set-up incl. the eigenpairs, fit, predict).
``--manifill-only LEVEL`` adds manifill alone on that level with ``--k-alone`` samples.
"""

import argparse
import math
import sys
import time

import numpy as np

from .gp_common import PriorSampler, Saver, matern_shape, random_samples, scores

RHO = 0.5
MEAN = 2.0
JITTER = 1e-6


def smooth(V):
    return np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * np.cos(3 * V[:, 1])


def gk_setup(V, F, num):
    """``(kernel, params, seconds, num)``: the space, the kernel and its eigenpairs (computed here)."""
    from geometric_kernels.kernels import MaternGeometricKernel
    from geometric_kernels.spaces import Mesh

    t0 = time.perf_counter()
    space = Mesh(np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64))
    kernel = MaternGeometricKernel(space) if num is None else MaternGeometricKernel(space, num=num)
    params = kernel.init_params()
    params["nu"] = np.array([1.0])
    params["lengthscale"] = np.array([1.0])
    x0 = np.zeros((1, 1), dtype=np.int64)
    kernel.K(params, x0, x0)  # the eigenpairs, if the constructor left them for the first call
    used = int(getattr(kernel, "num_levels", 0) or getattr(kernel, "num", 0) or (num or 0))
    return kernel, params, time.perf_counter() - t0, used


def _profiled(Kn, y):
    """Profiled ML: ``(neg. log-lik, beta, s2, cholesky)`` for ``y ~ N(beta 1, s2 (Kn + jitter I))``."""
    import scipy.linalg as la

    k = y.size
    A = Kn + JITTER * np.eye(k)
    c = la.cho_factor(A, lower=True)
    one = np.ones(k)
    ai1, aiy = la.cho_solve(c, one), la.cho_solve(c, y)
    beta = float(one @ aiy / (one @ ai1))
    r = y - beta
    air = aiy - beta * ai1
    s2 = float(r @ air / k)
    logdet = 2.0 * float(np.sum(np.log(np.diag(c[0]))))
    return 0.5 * (k * math.log(max(s2, 1e-300)) + logdet + k), beta, s2, c, ai1


def gk_run(kernel, params, idx, y, n):
    """Fit (lengthscale; mean and variance profiled) and predict at every vertex: ``(mean, std, info)``."""
    import scipy.linalg as la
    from scipy.optimize import minimize_scalar

    Xs = idx.reshape(-1, 1).astype(np.int64)
    t0 = time.perf_counter()
    evals = []

    def nll(loglen):
        p = dict(params, lengthscale=np.array([math.exp(loglen)]))
        v = _profiled(np.asarray(kernel.K(p, Xs, Xs)), y)[0]
        evals.append(v)
        return v

    res = minimize_scalar(nll, bounds=(math.log(0.005), math.log(5.0)), method="bounded",
                          options={"xatol": 1e-3})
    ell = math.exp(res.x)
    p = dict(params, lengthscale=np.array([ell]))
    Kn = np.asarray(kernel.K(p, Xs, Xs))
    _, beta, s2, c, ai1 = _profiled(Kn, y)
    t_fit = time.perf_counter() - t0
    t0 = time.perf_counter()
    Xa = np.arange(n, dtype=np.int64).reshape(-1, 1)
    Ka = np.asarray(kernel.K(p, Xa, Xs))  # (n, k)
    kd = np.asarray(kernel.K_diag(p, Xa)).ravel()
    W = la.cho_solve(c, Ka.T)  # (k, n)
    mean = beta + Ka @ la.cho_solve(c, y - beta)
    u = 1.0 - Ka @ ai1  # the mean's estimation term (universal kriging)
    var = s2 * (kd - np.einsum("ij,ji->i", Ka, W) + u * u / float(np.ones(idx.size) @ ai1))
    std = np.sqrt(np.maximum(var, 0.0))
    t_pred = time.perf_counter() - t0
    return mean, std, {"lengthscale": ell, "range": math.sqrt(8.0) * ell, "sigma": math.sqrt(s2),
                       "mean": beta, "evaluations": len(evals), "fit_seconds": t_fit, "predict_seconds": t_pred}


def mf_run(V, F, idx, y):
    import manifill

    t0 = time.perf_counter()
    r = manifill.reconstruct(V, F, idx, y, method="gp")
    g = r.report["gp"]
    return r.values, r.std, {"seconds": time.perf_counter() - t0, "range": g["range"][0], "sigma": g["sigma"][0],
                             "gp_seconds": g["seconds"], "variance": g["variance"]}


def one_level(level, k, num, log, gk=True):
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(level)
    n = len(V)
    idx = random_samples(n, k, 0)
    t0 = time.perf_counter()
    prior = PriorSampler(matern_shape(V, F), RHO, 1.0, MEAN).draw(np.random.default_rng([0, level, 13]))
    log(f"  level {level}: {n:,} vertices, prior draw in {time.perf_counter() - t0:.1f} s")
    fields = {"prior": prior, "smooth": smooth(V)}
    out = {"level": level, "vertices": n, "k": k, "fields": {}}
    for name, truth in fields.items():
        mean, std, info = mf_run(V, F, idx, truth[idx])
        out["fields"][name] = {"manifill": {**scores(truth, mean, std, idx), **info}}
        log(f"    {name} manifill: rmse {out['fields'][name]['manifill']['rmse']:.4f}, coverage "
            f"{out['fields'][name]['manifill']['coverage90']:.3f}, nlpd {out['fields'][name]['manifill']['nlpd']:.3f}, "
            f"range {info['range']:.3f}, {info['seconds']:.1f} s")
        yield out
    if not gk:
        return
    kernel, params, t_setup, used = gk_setup(V, F, num)
    out["gk_setup_seconds"] = t_setup
    out["gk_num"] = used
    log(f"    GeometricKernels set-up (eigenpairs, num={used}): {t_setup:.1f} s")
    for name, truth in fields.items():
        mean, std, info = gk_run(kernel, params, idx, truth[idx], n)
        row = {**scores(truth, mean, std, idx), **info,
               "seconds": t_setup + info["fit_seconds"] + info["predict_seconds"]}
        out["fields"][name]["geometric_kernels"] = row
        log(f"    {name} GeometricKernels: rmse {row['rmse']:.4f}, coverage {row['coverage90']:.3f}, nlpd "
            f"{row['nlpd']:.3f}, range {row['range']:.3f}, fit {info['fit_seconds']:.1f} s, predict "
            f"{info['predict_seconds']:.1f} s")
        yield out


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = argparse.ArgumentParser(prog="python -m bench.gp_peers", description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="5,6,7")
    ap.add_argument("--k", type=int, default=100)
    ap.add_argument("--num", default="default", help="GeometricKernels' eigenpairs: 'default' or a number")
    ap.add_argument("--manifill-only", type=int, default=None, help="a level run with manifill alone")
    ap.add_argument("--k-alone", type=int, default=1000)
    ap.add_argument("--save", default=None, help="JSON file, rewritten after every step")
    args = ap.parse_args(argv)
    num = None if args.num == "default" else int(args.num)
    save = Saver(args.save, "python -m bench.gp_peers " + " ".join(argv))

    def log(msg):
        print(msg, flush=True)

    for level in map(int, filter(None, args.levels.split(","))):
        for partial in one_level(level, args.k, num, log):
            save.put(f"level {level}", partial)
    if args.manifill_only is not None:
        for partial in one_level(args.manifill_only, args.k_alone, num, log, gk=False):
            save.put(f"level {args.manifill_only} manifill alone", partial)


if __name__ == "__main__":
    main()
