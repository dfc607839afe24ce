"""The methods compared: every manifill method and partition, and its peers, behind one signature.

Each method is a function ``(V, F, idx, vals) -> values at every vertex``. The
peers:

- libigl's harmonic (``igl.harmonic(V, F, b, bc, 1)``) and biharmonic (``k = 2``)
  interpolation with the samples as point constraints (cotangent Laplacian,
  and for k = 2 the mass-weighted bi-Laplacian);
- SciPy's ``RBFInterpolator`` with the thin-plate-spline kernel, smoothing 0, on
  the vertex positions (straight-line distance; on a flat mesh the constant
  coordinate is dropped, as the polynomial part would be singular);
- the nearest sample by geodesic distance: one multi-source Dijkstra on the
  mesh graph with edge-length weights (``manifill.mesh.graph``), every vertex
  takes the value of the sample it reaches first.
"""

import numpy as np

__all__ = ["METHODS", "Method", "run"]


class Method:
    """A named reconstruction method."""

    def __init__(self, name, family, fn, short):
        self.name, self.family, self.fn, self.short = name, family, fn, short

    def __repr__(self):
        return f"Method({self.name!r})"


def _manifill(**kw):
    def fn(V, F, idx, vals):
        from manifill import reconstruct

        return reconstruct(V, F, idx, vals, **kw).values

    return fn


def _igl_harmonic(k):
    def fn(V, F, idx, vals):
        import igl

        x = igl.harmonic(V, np.ascontiguousarray(F, dtype=np.int64), np.ascontiguousarray(idx, dtype=np.int64),
                         np.ascontiguousarray(vals, dtype=np.float64)[:, None], k)
        return np.asarray(x).ravel()

    return fn


def rbf_tps(V, F, idx, vals):
    """Thin-plate-spline RBF on the positions (their affine span), evaluated at every vertex."""
    from scipy.interpolate import RBFInterpolator

    P = V - V.mean(axis=0)
    _, s, Wt = np.linalg.svd(P[:: max(1, len(P) // 20000)], full_matrices=False)
    axes = Wt[s > 1e-9 * s[0]]
    P = P @ axes.T
    rbf = RBFInterpolator(P[idx], vals, kernel="thin_plate_spline", smoothing=0.0)
    return rbf(P)


def nearest_geodesic(V, F, idx, vals):
    """Value of the geodesically nearest sample (one multi-source Dijkstra, edge-length weights)."""
    from manifill.mesh.graph import mesh_graph, offset_distances

    G = mesh_graph(V, F, distance="length")
    _, root, _ = offset_distances(G, idx, np.zeros(len(idx)))
    if (root < 0).any():
        raise RuntimeError(f"{int((root < 0).sum()):,} vertices reach no sample (a component without samples)")
    return vals[root]


METHODS = [
    Method("manifill gvf-harmonic, delaunay, hermite (default)", "manifill", _manifill(), "mf default"),
    Method("manifill gvf-harmonic, tree, hermite", "manifill", _manifill(partition="tree"), "mf tree"),
    Method("manifill gvf-harmonic, cycle, hermite", "manifill", _manifill(partition="cycle"), "mf cycle"),
    Method("manifill gvf-harmonic, delaunay, linear", "manifill", _manifill(curve_values="linear"), "mf linear"),
    Method("manifill gvf-harmonic, delaunay, monotone", "manifill", _manifill(curve_values="monotone"),
           "mf monotone"),
    Method("manifill gvf-harmonic, delaunay, gvf", "manifill", _manifill(curve_values="gvf"), "mf gvf curves"),
    Method("manifill harmonic (point constraints)", "manifill", _manifill(method="harmonic"), "mf harmonic"),
    Method("manifill gvf (no harmonic fill)", "manifill", _manifill(method="gvf"), "mf gvf"),
    Method("manifill biharmonic (point constraints)", "manifill", _manifill(method="biharmonic"), "mf biharmonic"),
    Method("manifill biharmonic, bounds=samples", "manifill", _manifill(method="biharmonic", bounds="samples"),
           "mf bounded biharmonic"),
    Method("libigl harmonic (k=1, points)", "peer", _igl_harmonic(1), "igl harmonic"),
    Method("libigl biharmonic (k=2, points)", "peer", _igl_harmonic(2), "igl biharmonic"),
    Method("SciPy RBF thin-plate spline (xyz)", "peer", rbf_tps, "RBF TPS"),
    Method("nearest sample (geodesic, Dijkstra)", "peer", nearest_geodesic, "nearest"),
]


def one_line(exc):
    """An exception as one short line for a table cell."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    text = text.replace("|", "/")
    return text if len(text) <= 110 else text[:107] + "..."


def run(method, V, F, idx, vals):
    """``(values, seconds, None)``, or ``(None, seconds, reason)`` when the method fails.

    Non-finite output counts as a failure (libigl returns NaN, or nothing
    useful, where a component has no constraint).
    """
    import time

    t0 = time.perf_counter()
    try:
        x = np.asarray(method.fn(V, F, idx, vals), dtype=np.float64).ravel()
    except Exception as exc:  # a failing method is a result, not a crash
        return None, time.perf_counter() - t0, f"{type(exc).__name__}: {one_line(exc)}"
    sec = time.perf_counter() - t0
    if x.shape != (len(V),):
        return None, sec, f"returned shape {x.shape}"
    bad = ~np.isfinite(x)
    if bad.any():
        return None, sec, f"{int(bad.sum()):,} non-finite values"
    return x, sec, None
