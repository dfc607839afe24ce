"""A prepared reconstruction: one mesh and one sample set, many fields (time series, subjects, channels).

:class:`Reconstructor` does once what does not depend on the sample values -- validation, the
graph, the Laplacian, the partition (Steps 2-3), the fill's factorisation or AMG hierarchy,
Step 4's linear map, the mesh and samples made ready (:class:`~manifill.surface.domain.Domain`: vertices
no face uses left out, the cut along barriers, samples given as positions located) -- and :meth:`Reconstructor.apply`
then runs the rest for any values, ``(k,)`` or ``(k, p)``, giving what
:func:`manifill.reconstruct` gives for them (which is a Reconstructor applied once).

Linear in the values are: ``harmonic``, ``biharmonic`` and ``triharmonic`` without bounds
(``smoothing`` None or a number), ``gvf-harmonic`` with ``hermite`` or ``linear`` curve values
and no bounds, ``rbf``, and ``gp`` with its range, sigma and noise given. For those
:meth:`Reconstructor.matrix` gives the n x k interpolation map ``W`` with ``W @ vals ==
apply(vals).values``. The rest is not linear in the values: the default (the biharmonic projected
onto the samples' range: the map's field, then a clip per field), any ``bounds``, ``gvf`` (levels),
``smoothing='auto'`` (lambda chosen per field), ``auto`` (a method chosen per call) and ``gp`` with
fitted hyperparameters; they still reuse everything value-independent.
"""

import math
import time
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator

from ..errors import OptionError
from ..linalg.quadratic import QuadraticSolver
from ..memory import check_fits
from ..validate import check_option
from ..validate.objects import is_mesh_object
from .domain import Domain
from .energy_fill import as_bounds
from .engine import reconstruct_surface
from .methods.registry import configure, method_of
from .options import Options
from .prepared import Prepared
from .reconstruction import Reconstruction
from .surface import Surface

__all__ = ["Reconstructor", "MATRIX_FORMS"]

#: What :meth:`Reconstructor.matrix` returns: the pipeline's sparse map or an operator (``auto``), or either.
MATRIX_FORMS = ("auto", "sparse", "operator")

#: Unit columns per block while :meth:`Reconstructor.matrix` builds a sparse map.
MATRIX_BLOCK = 64


class Reconstructor:
    """Reconstruct many fields on one mesh from one sample set: prepared once, applied to any values.

    Parameters
    ----------
    V, F, idx
        As for :func:`manifill.reconstruct` (vertex indices or positions).
    options : Options, optional
        The options, built once (:class:`manifill.surface.options.Options`); or
    **keywords
        The options of :func:`manifill.reconstruct` (``method``, ``solver``, ``bounds``, ...), which build
        them (or change the given ``options``).
    fields : int, optional
        How many fields you will reconstruct in all (a hint; None: many). With
        many, ``solver='auto'`` factorises the fill when the factors fit in memory
        (a pair of triangular solves per field, against a CG run), and Step 4's
        linear curve values are one sparse map.
    prepare : bool, optional
        Build the solver now (True) or at the first :meth:`apply`.
    progress : callable, optional
        Called with the name of each step of the preparation as it starts.

    Attributes
    ----------
    options : Options
        The configured options (the default preset resolved, ``sample_weights`` in vertex order).
    method : str
        The method that runs.
    surface : Surface
    samples : int
        Rows of the values :meth:`apply` takes.
    linear : bool
        Whether the result is linear in the values (see the module docstring).
    seconds : dict
        Time spent preparing, by step.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(3)
    >>> idx = np.arange(0, 642, 40)
    >>> rec = Reconstructor(V, F, idx, method="harmonic")
    >>> X = rec.apply(np.column_stack([V[idx, 0], V[idx, 2]])).values     # two fields, (642, 2)
    >>> W = rec.matrix()                                                  # (642, 17) operator
    >>> bool(np.allclose(W @ V[idx, 0], X[:, 0]))
    True
    """

    def __init__(self, V: ArrayLike, F: ArrayLike | None, idx: ArrayLike, *, options: Options | None = None,
                 fields: int | None = None, prepare: bool = True, progress: Callable[[str], object] | None = None,
                 **keywords: Any) -> None:
        t0 = time.perf_counter()
        o = configure(options, **keywords)
        if fields is not None and not (isinstance(fields, (int, np.integer)) and fields >= 1):
            raise OptionError(f"fields={fields!r} is not a whole number >= 1 (how many fields you will "
                              f"reconstruct); pass one, or None for many")
        self._source = V if is_mesh_object(V) else None  # its own arrays go back out with the result
        self.method, self._method = o.method, method_of(o.method)
        self._domain = Domain(V, F, idx, o, self._method)
        self.default = o.preset is not None
        self.samples = self._domain.samples
        weights = self._domain.sample_weights(o.fit.sample_weights)
        self.options = o if weights is None else configure(o.replace(sample_weights=weights))  # checked once
        self.seconds = {"validate": time.perf_counter() - t0}
        t = time.perf_counter()
        self.surface = _surface(self._domain, o)
        self.seconds["graph"] = time.perf_counter() - t
        self.fields = math.inf if fields is None else int(fields)
        self.linear, self._why = self._method.linearity(self.options)
        self._prepared = Prepared()
        if prepare:
            self._prepare(progress)

    @property
    def n(self) -> int:
        """Rows of the results: the caller's vertices (before any left out, and before a barrier's cut)."""
        return self._domain.n

    def mesh(self) -> tuple[np.ndarray, np.ndarray | None]:
        """``(V, F)`` in the caller's numbering (``F`` None for a point cloud): what the results are on."""
        return self._domain.mesh()

    def __getstate__(self):
        """What a pickle holds: the mesh and the plain prepared pieces, not the process-local solvers.

        The surface goes as its domain's arrays (its graphs and Laplacians are rebuilt in a few
        hundredths of the preparation's time); the partition, Step 4's curve map and the
        energy matrix go as they are; the fill's and the energy's solvers (a factorisation
        or an AMG hierarchy, which cannot leave their process) are left out, and built again by
        the first :meth:`apply` where the Reconstructor lands, with the same options and
        ``fields`` hint, so that it gives the same values.
        """
        state = dict(self.__dict__)
        state["surface"] = None  # the domain holds its arrays
        state["_prepared"] = {k: v for k, v in self._prepared.items() if not _process_local(v)}
        return state

    def __setstate__(self, state):
        """Rebuild the surface; the solvers wait for the first :meth:`apply` (``prepared.cached``)."""
        self.__dict__.update(state)
        self.surface = _surface(self._domain, self.options)
        self._prepared = Prepared(state["_prepared"])

    def _prepare(self, progress):
        """Build the value-independent pieces by one run on zero values, without Step 1, bounds or the std."""
        if not self._method.preparable(self.options):
            return
        t = time.perf_counter()
        zeros = np.zeros((self.samples, 1))
        self._run(zeros, self._plain(bounds=None), "mean")
        self.seconds["prepare"] = time.perf_counter() - t

    def _plain(self, **more):
        """The options without Step 1, the std or the trust mask (the pieces values do not need)."""
        gp = self.options.uq.gp if self._method.gp_mean else None
        return self.options.replace(uncertainty=False, trust=None, check=False, gp=gp, **more)

    def _samples(self, vals, duplicates):
        """``(idx, vals, points, squeeze, given)`` for values in the caller's rows (:meth:`Domain.place`)."""
        return self._domain.place(vals, duplicates)

    def _run(self, vals, options, duplicates, progress=None):
        t0 = time.perf_counter()
        idx, v, points, squeeze, given = self._samples(vals, duplicates)
        if options.fit.bounds is not None:  # samples outside the bounds are named by the caller's row
            as_bounds(options.fit.bounds, given)
        seconds = {"validate": time.perf_counter() - t0}
        r = reconstruct_surface(self.surface, idx, v, options=options, progress=progress, seconds=seconds,
                                points=points, fields=self.fields, prepared=self._prepared)
        r.report["default"] = self.default
        r.source = self._source
        smoothed = r.report.get("fill", {}).get("smoothing")
        if smoothed is not None:  # residuals in the caller's rows and shape
            at = self._domain.at_samples(r)
            smoothed["residuals"] = (at - given)[:, 0] if squeeze else at - given
        if squeeze:
            r.values = r.values[:, 0]
            r.std = None if r.std is None else r.std[:, 0]
        return self._domain.expand(r)

    def apply(self, vals: ArrayLike, *, progress: Callable[[str], object] | None = None) -> Reconstruction:
        """The reconstruction of ``vals``: what :func:`manifill.reconstruct` gives for them.

        Parameters
        ----------
        vals : (k,) or (k, p) array_like of float
            One row per sample, in the order given to the constructor; one column per field.
        progress : callable, optional
            Called with the name of each step as it starts.

        Returns
        -------
        Reconstruction
            ``report['seconds']`` holds this call's steps (the preparation's are in :attr:`seconds`).

        Raises
        ------
        SampleError
            Values with another number of rows, NaN, conflicting duplicates, values outside ``bounds``.
        """
        return self._run(vals, self.options, self.options.points.duplicates, progress)

    def check_values(self, vals: ArrayLike) -> None:
        """Refuse values as :meth:`apply` would (shape, NaN, conflicting duplicates), without solving anything.

        Raises
        ------
        SampleError
            As :meth:`apply`.
        """
        self._samples(vals, self.options.points.duplicates)

    def matrix(self, *, form: Literal["auto", "sparse", "operator"] = "auto") -> sp.csr_array | LinearOperator:
        """The interpolation map ``W`` (n x k) with ``W @ vals == apply(vals).values``, for the linear methods.

        Parameters
        ----------
        form : {'auto', 'sparse', 'operator'}, optional
            ``sparse``: a ``scipy.sparse.csr_array``, built column block by column block
            (costs ``k`` fields' solves; exact zeros dropped; the pipeline's map is
            sparse, each vertex depending on the samples around its patch); ``operator``:
            a ``scipy.sparse.linalg.LinearOperator`` that calls :meth:`apply` (the
            energy methods' maps are dense: every vertex depends on every sample);
            ``auto``: sparse for ``gvf-harmonic``, an operator otherwise.

        Returns
        -------
        scipy.sparse.csr_array or scipy.sparse.linalg.LinearOperator

        Raises
        ------
        OptionError
            The method, as configured, is not linear in the values (the message says why).
        ResourceError
            A sparse map whose blocks would not fit in memory.
        """
        check_option("form", form, MATRIX_FORMS)
        if not self.linear:
            raise OptionError(f"this reconstruction is not linear in the sample values ({self._why}), so it has no "
                              f"matrix; use apply(vals), or a linear configuration (e.g. method='gvf-harmonic' with "
                              f"curve_values='hermite', or method='harmonic', without bounds)")
        n, k = self.n, self.samples
        options = self._plain()
        if form == "auto":
            form = "sparse" if self._method.sparse_map else "operator"
        if form == "operator":
            def matmat(X):
                return np.asarray(self._run(np.asarray(X).reshape(k, -1), options, "mean").values).reshape(n, -1)

            return LinearOperator((n, k), matvec=lambda x: matmat(x).ravel(), matmat=matmat, dtype=np.float64)
        check_fits(8.0 * n * min(MATRIX_BLOCK, k) * 2, f"a block of {min(MATRIX_BLOCK, k)} columns of the {n:,} x "
                   f"{k:,} map", "use form='operator'")
        blocks = []
        for start in range(0, k, MATRIX_BLOCK):
            E = np.zeros((k, min(MATRIX_BLOCK, k - start)))
            E[np.arange(start, start + E.shape[1]), np.arange(E.shape[1])] = 1.0
            X = np.asarray(self._run(E, options, "mean").values).reshape(n, -1)
            blocks.append(sp.csr_array(np.where(np.isnan(X), 0.0, X)))
        W = sp.csr_array(sp.hstack(blocks, format="csr"))
        W.eliminate_zeros()
        return W


def _surface(domain, options):
    """The domain's arrays as a Surface: a mesh (cut along barriers, or with Bakka's barrier faces), or a point cloud
    when its ``F`` is None."""
    if domain.F is None:
        return Surface.from_points(domain.V, neighbours=options.fill.neighbours, distance=options.fill.distance,
                                   check=False)
    surface = Surface.from_mesh(domain.V, domain.F, distance=options.fill.distance, check=False, cut=domain.cut)
    surface.barrier_faces = domain.barrier_faces
    return surface


def _process_local(piece):
    """Whether a prepared piece holds a solver that cannot leave its process (a factorisation, an AMG hierarchy)."""
    return isinstance(piece, QuadraticSolver)  # the fill's HarmonicSolver is one
