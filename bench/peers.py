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
  takes the value of the sample it reaches first;
- potpourri3d's vector heat method, ``MeshVectorHeatSolver(V, F).extend_scalar(idx, vals)``
  (Sharp, Soliman and Crane 2019: each vertex gets the value of the nearest
  sample by the diffused geodesic distance, smoothly blended);
- pyvista's Gaussian-kernel ``DataSet.interpolate`` from the sample points to
  the mesh (a point-cloud kernel average, not an interpolant), with the radius
  set from the samples' spacing (:func:`gaussian_kernel`);
- MNE-Python's spherical spline (Perrin et al. 1989, the interpolation of
  ``interpolate_bads``), on the head case only (:func:`mne_spline`).

Peers that are benchmark-only dependencies (potpourri3d, mne) are imported
inside their functions; a missing one makes its row "not installed"
(:class:`Skip`), never a crash. So does a method that does not apply to a case
(``Method.cases``).

manifill's rows call ``reconstruct`` with the options in their names (``smoothing='auto'``: lambda by
generalised cross-validation; ``method='auto'``: cross-validation of the candidates); a row whose method or
option manifill does not offer (yet) shows the error as its failure reason.
"""

import numpy as np

__all__ = ["METHODS", "Method", "Skip", "run"]


class Skip(Exception):
    """A method that cannot run here (not installed, or not for this case): a note, not a failure."""


class Method:
    """A named reconstruction method.

    ``cases``: the case keys it runs on (None: every case); ``smoke``: the case
    keys it runs on under ``--smoke`` (None: the same); ``ks``: the random-sample
    k it runs at in the full run (None: all; fixed layouts always run), for
    the slow ones.
    """

    def __init__(self, name, family, fn, short, cases=None, smoke=None, ks=None):
        self.name, self.family, self.fn, self.short, self.cases = name, family, fn, short, cases
        self.smoke, self.ks = smoke, ks

    def __repr__(self):
        return f"Method({self.name!r})"


def _manifill(**kw):
    def fn(V, F, idx, vals):
        from manifill import reconstruct

        return reconstruct(V, F, idx, vals, **kw).values

    return fn


def _igl_harmonic(k, clip=False):
    def fn(V, F, idx, vals):
        import igl

        x = igl.harmonic(V, np.ascontiguousarray(F, dtype=np.int64), np.ascontiguousarray(idx, dtype=np.int64),
                         np.ascontiguousarray(vals, dtype=np.float64)[:, None], k)
        x = np.asarray(x).ravel()
        return np.clip(x, np.min(vals), np.max(vals)) if clip else x

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


def _need(module):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise Skip(f"not installed ({module}: pip install {PIP.get(module, module)})") from exc


PIP = {"potpourri3d": "potpourri3d", "mne": "mne", "pyvista": "pyvista"}


def vector_heat(V, F, idx, vals):
    """potpourri3d's ``MeshVectorHeatSolver(V, F).extend_scalar(idx, vals)``."""
    pp3d = _need("potpourri3d")
    try:
        solver = pp3d.MeshVectorHeatSolver(np.ascontiguousarray(V, dtype=np.float64),
                                           np.ascontiguousarray(F, dtype=np.int64))
    except RuntimeError as exc:  # geometry-central's assertion: keep its reason, drop the source path
        raise RuntimeError("geometry-central: " + str(exc).rsplit(" - ", 1)[-1]) from exc
    return solver.extend_scalar(np.ascontiguousarray(idx, dtype=np.int64), np.ascontiguousarray(vals, np.float64))


GAUSS_RADIUS, GAUSS_SHARPNESS = 3.0, 3.0  # the best of the settings tried (gaussian_kernel's docstring)


def sample_spacing(P):
    """Mean distance from each sample point to its nearest other sample."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(P).query(P, k=2)
    return float(d[:, 1].mean())


def gaussian_kernel(V, F, idx, vals, radius=GAUSS_RADIUS, sharpness=GAUSS_SHARPNESS):
    """pyvista's ``interpolate``: radius ``radius`` x the samples' mean nearest-neighbour spacing.

    VTK's Gaussian kernel weighs a sample at distance ``r`` by
    ``exp(-(sharpness r / R)^2)`` over the samples within ``R``; a vertex with
    none within ``R`` takes the closest sample (``strategy='closest_point'``).

    The rule: the kernel's width ``R / sharpness`` is the samples' spacing
    ``d``, its support ``R = 3 d``. Tried on the smoke cases (sphere-smooth,
    u-strip, airplane; k = 10, 30): (R, sharpness) = (d, 1), (1.5 d, 1),
    (2 d, 1), (2 d, 2), (3 d, 2), (3 d, 3), (3 d, 4.5), (4 d, 4); (3 d, 3) had
    the lowest rel. RMSE (or tied with (4 d, 4): a wider support no longer
    matters) on 4 of the 6 (case, k) and was within 1.25x of the best on the
    other two; that is the row.
    """
    pv = _need("pyvista")
    R = radius * sample_spacing(V[idx])
    cloud = pv.PolyData(np.ascontiguousarray(V[idx], dtype=np.float64))
    cloud.point_data["u"] = np.asarray(vals, dtype=np.float64)
    faces = np.column_stack([np.full(len(F), 3), F]).astype(np.int64).ravel()
    mesh = pv.PolyData(np.ascontiguousarray(V, dtype=np.float64), faces)
    out = mesh.interpolate(cloud, sharpness=sharpness, radius=R, strategy="closest_point")
    return np.asarray(out.point_data["u"], dtype=np.float64)


def mne_spline(V, F, idx, vals, alpha=1e-5):
    """MNE's spherical spline from the sample vertices to every vertex (``interpolate_bads``' interpolation).

    ``mne.channels.interpolation._make_interpolation_matrix(P[idx] - o, P - o, alpha=1e-5)``, a private
    helper of MNE (the matrix ``interpolate_bads`` and the public ``Evoked.interpolate_to(montage,
    method='spline')`` build; ``alpha = 1e-5`` is ``interpolate_bads``' regularisation, so the spline
    smooths slightly and does not pass exactly through the samples). ``o`` is the least-squares sphere
    of the sample positions (``origin='auto'`` fits the head's digitisation, here the sensors). The
    public route ``interpolate_to`` with the samples as channels and every vertex as the target montage
    gives the same values (checked: difference 0.0 at 10k vertices) but spends most of its time building
    a 41k-channel ``Info`` (30 s per call at 41k vertices against under 1 s), which would distort the
    time column. With 41k-vertex heads and the three montages the regularised spline misses the samples
    by 20-30 % of their range and the exact one (:func:`mne_spline_exact`, a second row) does not, so both
    are shown.
    """
    _need("mne")
    from mne.channels.interpolation import _make_interpolation_matrix

    from .fields_more import fit_sphere

    P = np.asarray(V, dtype=np.float64)
    origin, _ = fit_sphere(P[idx])
    M = _make_interpolation_matrix(P[idx] - origin, P - origin, alpha=alpha)
    return M @ np.asarray(vals, dtype=np.float64)


def mne_spline_exact(V, F, idx, vals):
    """:func:`mne_spline` without regularisation (``alpha=None``): through the samples exactly."""
    return mne_spline(V, F, idx, vals, alpha=None)


METHODS = [
    Method("manifill default (biharmonic, projected onto the samples' range)", "manifill", _manifill(), "mf default"),
    Method("manifill gvf-harmonic, monotone, bounds=samples (the default before issue 37)", "manifill",
           _manifill(method="gvf-harmonic", curve_values="monotone", bounds="samples"), "mf pipeline bounded"),
    Method("manifill gvf-harmonic, delaunay, hermite (the paper's pipeline)", "manifill",
           _manifill(method="gvf-harmonic"), "mf hermite"),
    Method("manifill gvf-harmonic, tree, hermite", "manifill", _manifill(method="gvf-harmonic", partition="tree"),
           "mf tree"),
    Method("manifill gvf-harmonic, cycle, hermite", "manifill", _manifill(method="gvf-harmonic", partition="cycle"),
           "mf cycle"),
    Method("manifill gvf-harmonic, delaunay, linear", "manifill",
           _manifill(method="gvf-harmonic", curve_values="linear"), "mf linear"),
    Method("manifill gvf-harmonic, delaunay, monotone", "manifill",
           _manifill(method="gvf-harmonic", curve_values="monotone"), "mf monotone"),
    Method("manifill gvf-harmonic, delaunay, gvf", "manifill", _manifill(method="gvf-harmonic", curve_values="gvf"),
           "mf gvf curves"),
    Method("manifill harmonic (point constraints)", "manifill", _manifill(method="harmonic"), "mf harmonic"),
    Method("manifill gvf (no harmonic fill)", "manifill", _manifill(method="gvf"), "mf gvf"),
    Method("manifill biharmonic (point constraints)", "manifill", _manifill(method="biharmonic"), "mf biharmonic"),
    Method("manifill biharmonic, bounds=samples", "manifill", _manifill(method="biharmonic", bounds="samples"),
           "mf bounded biharmonic"),
    Method("manifill biharmonic, bounds=samples, projected", "manifill",
           _manifill(method="biharmonic", bounds="samples", bounds_mode="project"), "mf projected biharmonic"),
    Method("manifill triharmonic, bounds=samples, projected", "manifill",
           _manifill(method="triharmonic", bounds="samples", bounds_mode="project"), "mf projected triharmonic"),
    Method("manifill hessian (flat Hessian energy)", "manifill", _manifill(method="hessian"), "mf hessian"),
    Method("manifill hessian, bounds=samples, projected", "manifill",
           _manifill(method="hessian", bounds="samples", bounds_mode="project"), "mf projected hessian"),
    Method("manifill hessian-curved", "manifill", _manifill(method="hessian-curved"), "mf curved hessian"),
    Method("manifill hessian-curved, bounds=samples, projected", "manifill",
           _manifill(method="hessian-curved", bounds="samples", bounds_mode="project"), "mf projected curved hessian"),
    Method("manifill gvf-harmonic, hermite, bounds=samples", "manifill",
           _manifill(method="gvf-harmonic", bounds="samples"), "mf bounded hermite"),
    Method("manifill triharmonic (point constraints)", "manifill", _manifill(method="triharmonic"),
           "mf triharmonic"),
    Method("manifill harmonic, smoothing=auto", "manifill", _manifill(method="harmonic", smoothing="auto"),
           "mf harmonic smooth"),
    Method("manifill biharmonic, smoothing=auto", "manifill", _manifill(method="biharmonic", smoothing="auto"),
           "mf biharmonic smooth"),
    Method("manifill rbf", "manifill", _manifill(method="rbf"), "mf rbf"),
    # auto cross-validates 5 candidates over 5 folds: about 25 fits per call, so in the full run it runs at
    # k = 100 only (the targets' k), with both seeds; under --smoke on sphere-smooth only
    Method("manifill auto", "manifill", _manifill(method="auto"), "mf auto", smoke=("sphere-smooth",), ks=(100,)),
    Method("libigl harmonic (k=1, points)", "peer", _igl_harmonic(1), "igl harmonic"),
    Method("libigl biharmonic (k=2, points)", "peer", _igl_harmonic(2), "igl biharmonic"),
    Method("libigl biharmonic clipped to the samples' range", "peer", _igl_harmonic(2, clip=True),
           "igl biharmonic clipped"),
    Method("SciPy RBF thin-plate spline (xyz)", "peer", rbf_tps, "RBF TPS"),
    Method("nearest sample (geodesic, Dijkstra)", "peer", nearest_geodesic, "nearest"),
    Method("potpourri3d vector heat extend_scalar", "peer", vector_heat, "vector heat"),
    Method("pyvista Gaussian kernel interpolate", "peer", gaussian_kernel, "pv gaussian"),
    Method("MNE spherical spline (interpolate_bads, reg 1e-5)", "peer", mne_spline, "MNE spline",
           cases=("head-eeg",)),
    Method("MNE spherical spline, reg 0 (exact)", "peer", mne_spline_exact, "MNE spline exact", cases=("head-eeg",)),
]


def one_line(exc):
    """An exception as one short line for a table cell."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    text = text.replace("|", "/")
    return text if len(text) <= 110 else text[:107] + "..."


def run(method, V, F, idx, vals):
    """``(values, seconds, None)``, or ``(None, seconds, reason)`` when the method fails.

    :class:`Skip` (not installed) propagates: the caller marks the row, it is no failure.

    Non-finite output counts as a failure (libigl returns NaN, or nothing
    useful, where a component has no constraint).
    """
    import time

    t0 = time.perf_counter()
    try:
        x = np.asarray(method.fn(V, F, idx, vals), dtype=np.float64).ravel()
    except Skip:
        raise
    except Exception as exc:  # a failing method is a result, not a crash
        return None, time.perf_counter() - t0, f"{type(exc).__name__}: {one_line(exc)}"
    sec = time.perf_counter() - t0
    if x.shape != (len(V),):
        return None, sec, f"returned shape {x.shape}"
    bad = ~np.isfinite(x)
    if bad.any():
        return None, sec, f"{int(bad.sum()):,} non-finite values"
    return x, sec, None
