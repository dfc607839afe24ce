"""Shared pieces of the ``method='gp'`` benchmarks: prior draws, predictive metrics, incremental JSON.

- :func:`matern_shape`: the Matérn SPDE shape manifill's ``method='gp'`` builds on a triangle mesh;
- :func:`prior_draw`: a field from that prior, ``x = mean + Q~^-1 B' w / tau`` (``B' B = Q~``,
  ``w`` white noise), whose covariance is ``Q^-1 = (tau^2 Q~)^-1``: range ``rho``, marginal
  standard deviation ``sigma``;
- :func:`scores`: relative RMSE (the accuracy benchmark's: RMSE off the samples / range of the
  truth), coverage of the central 90 % interval, mean standardised squared error and mean
  negative log predictive density over the vertices that are not samples;
- :class:`Saver`: results written to JSON after every step, so a stopped run keeps its figures.
"""

import json
import math
import os
import platform
import time
from pathlib import Path

import numpy as np

__all__ = ["Z90", "matern_shape", "prior_draw", "scores", "Saver", "environment", "random_samples"]

#: The 95 % quantile of the standard normal: the central 90 % interval is mean +/- Z90 std.
Z90 = 1.6448536269514722


def matern_shape(V, F, alpha=2):
    """The :class:`manifill.linalg.spde.MaternShape` of ``method='gp'`` (cotangent stiffness, lumped mass)."""
    from manifill.mesh.laplacian import laplacian, mass_matrix
    from manifill.mesh.roots import gradient_root
    from manifill.linalg.spde import MaternShape

    return MaternShape(laplacian(V, F), mass_matrix(V, F).diagonal(), gradient_root(V, F), alpha, 2)


class PriorSampler:
    """Draws of the Matérn field of range ``rho`` and marginal std ``sigma`` (one factorisation, many draws)."""

    def __init__(self, shape, rho, sigma=1.0, mean=0.0):
        from manifill.linalg.factorise import factorise
        from manifill.linalg.spde import kappa_from_range, tau_from_sigma

        self.kappa = kappa_from_range(rho, shape.alpha, shape.d)
        self.tau = tau_from_sigma(sigma, self.kappa, shape.alpha, shape.d)
        self.B = shape.root(self.kappa)
        self.name, self.factor = factorise(shape.precision(self.kappa).tocsc())
        self.rho, self.sigma, self.mean = rho, sigma, mean

    def draw(self, rng):
        w = rng.standard_normal(self.B.shape[0])
        return self.mean + np.asarray(self.factor.solve(self.B.T @ w)).ravel() / self.tau


def prior_draw(V, F, rho, sigma=1.0, mean=0.0, seed=0):
    """One draw of the Matérn (``alpha = 2``) prior on the mesh."""
    return PriorSampler(matern_shape(V, F), rho, sigma, mean).draw(np.random.default_rng(seed))


def random_samples(n, k, seed):
    """``k`` distinct sorted vertices (seed ``(seed, k)``, as the accuracy benchmark draws them)."""
    return np.sort(np.random.default_rng([int(seed), int(k)]).choice(n, size=k, replace=False))


def scores(truth, mean, std, idx, span=None):
    """Predictive scores off the samples.

    Returns ``rmse`` (relative to the truth's range), ``coverage90``, ``z2`` (mean of
    ``((truth - mean) / std)^2``) and ``nlpd`` (mean of ``0.5 log(2 pi std^2) + 0.5 z^2``);
    vertices with ``std == 0`` off the samples are counted in ``zero_std`` and left out of the
    last three.
    """
    free = np.ones(len(truth), dtype=bool)
    free[idx] = False
    span = float(np.ptp(truth)) if span is None else span
    err = mean[free] - truth[free]
    s = None if std is None else std[free]
    out = {"rmse": float(np.sqrt(np.mean(err ** 2)) / (span or 1.0))}
    if s is not None:
        ok = s > 0
        z = err[ok] / s[ok]
        out.update({"coverage90": float(np.mean(np.abs(z) <= Z90)), "within196": float(np.mean(np.abs(z) <= 1.96)),
                    "z2": float(np.mean(z * z)),
                    "nlpd": float(np.mean(0.5 * np.log(2 * math.pi * s[ok] ** 2) + 0.5 * z * z)),
                    "zero_std": int((~ok).sum())})
    return out


def environment():
    import importlib.metadata

    out = {"python": platform.python_version(), "machine": platform.platform(), "cores": os.cpu_count()}
    for name in ("numpy", "scipy", "pypardiso", "manifill", "geometric_kernels", "robust_laplacian"):
        try:
            out[name] = importlib.metadata.version(name.replace("_", "-"))
        except importlib.metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


class Saver:
    """A JSON document written again after every :meth:`put` (partial results survive a stop)."""

    def __init__(self, path, command):
        self.path = None if path is None else Path(path)
        self.doc = {"command": command, "started": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
                    "environment": environment(), "results": {}}

    def put(self, key, value):
        self.doc["results"][key] = value
        self.write()

    def write(self):
        if self.path is None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_suffix(self.path.suffix + ".tmp")
        tmp.write_text(json.dumps(self.doc, indent=1, default=_jsonable), encoding="utf-8")
        tmp.replace(self.path)


def _jsonable(x):
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"not JSON: {type(x).__name__}")
