"""The one result family: values on a domain, manifill's masks, a report.

Every reconstruction returns a :class:`Result`: on a surface
:class:`manifill.surface.reconstruct.Reconstruction` (Steps 1-6), on a solid
:class:`manifill.solid.reconstruct_volume.VolumeReconstruction` (tets or voxels,
Steps 1-8). A result has

- ``values``: the field(s) at every point of its domain, a last axis per field
  when there are several;
- ``report``: a dict of diagnostics, with ``seconds`` per step;
- :meth:`Result.masks`: manifill's mask and label arrays, under the names below
  (the same in every output file);
- :meth:`Result.point_data`: the fields, named, and the masks: what is written;
- :meth:`Result.to_pyvista`, :meth:`Result.to_meshio`: the domain as an object of
  those libraries (each result says what it can give);
- :attr:`Result.names` (the fields' names), :meth:`Result.save` (any format
  :mod:`manifill.io` writes, which registers itself here: results sit below it)
  and a short ``repr`` (what ran, the counts, each field's range, the time).

The mask names live here, at the base of the package, so that results and the file
formats of :mod:`manifill.io` use one naming scheme.
"""

from __future__ import annotations

import os
from abc import ABC, abstractmethod
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Literal, overload

import numpy as np

from .errors import OptionError, SampleError

if TYPE_CHECKING:  # the types of the optional objects a result converts to
    import meshio
    import pyvista

__all__ = ["SAMPLE_MASK", "CURVE_MASK", "PATCH_LABEL", "BOUNDARY_MASK", "TRUSTED", "RESERVED_NAMES", "Result",
           "field_names", "with_std", "sample_mask", "register_saver"]

#: 1 where a vertex (or voxel) holds a sample
SAMPLE_MASK = "sample_mask"
#: 1 on the partition curves (their values were fixed before the harmonic fill)
CURVE_MASK = "curve_mask"
#: the patch of every vertex, -1 on the curves
PATCH_LABEL = "patch_label"
#: 1 on the boundary of a solid (tet vertices on its surface; voxels of D, filled from the surface)
BOUNDARY_MASK = "boundary_mask"
#: 1 where the standard deviation is within the ``trust`` threshold (with ``trust=``)
TRUSTED = "trusted"
RESERVED_NAMES = (SAMPLE_MASK, CURVE_MASK, PATCH_LABEL, BOUNDARY_MASK, TRUSTED)

#: Fields named in a result's repr before "... and N more".
REPR_FIELDS = 6

_SAVER: list = []  # the writer of :meth:`Result.save`, registered by manifill.io (a layer above)


def register_saver(save):
    """Make ``save(result, path, names)`` the writer of :meth:`Result.save` (called by :mod:`manifill.io`)."""
    _SAVER[:] = [save]


def field_names(names, p):
    """Check ``p`` field names, or make ``value, value2, ...``.

    Parameters
    ----------
    names : list of str or None
        Given names.
    p : int
        Number of value columns.

    Returns
    -------
    list of str

    Raises
    ------
    SampleError
        If the count does not match, or a name repeats.

    Examples
    --------
    >>> field_names(None, 3)
    ['value', 'value2', 'value3']
    """
    if names is None:
        return ["value"] + [f"value{j + 1}" for j in range(1, p)]
    names = [str(s) for s in names]
    if len(names) != p:
        raise SampleError(f"{len(names)} field names for {p} value columns; give one name per column")
    seen = set()
    for name in names:
        if name in seen:
            raise SampleError(f"the value column name {name!r} repeats; give each value column its own name")
        seen.add(name)
    return names


def with_std(data, std, names, point_ndim=1):
    """``data`` (fields first, then masks) with each field's ``<name>_std`` after the fields, when ``std`` is given.

    Raises
    ------
    SampleError
        A field's name is another field's ``<name>_std``.

    Examples
    --------
    >>> d = with_std({"t": np.zeros(2), "sample_mask": np.ones(2)}, np.ones(2), ["t"])
    >>> list(d)
    ['t', 't_std', 'sample_mask']
    """
    if std is None:
        return data
    S = std if std.ndim == point_ndim + 1 else std[..., None]
    keys = field_names(names, S.shape[-1])
    clash = [f"{key}_std" for key in keys if f"{key}_std" in keys]
    if clash:
        raise SampleError(f"the field name {clash[0]!r} is taken by the standard deviation of another field; "
                          f"rename that field")
    out = {key: data.pop(key) for key in keys}
    out.update({f"{key}_std": S[..., j] for j, key in enumerate(keys)})
    return {**out, **data}


def sample_mask(n, idx):
    """The :data:`SAMPLE_MASK` array of ``n`` points: True at the samples ``idx``.

    Parameters
    ----------
    n : int
        Number of points (vertices).
    idx : (k,) array_like of int
        The sample points.

    Returns
    -------
    (n,) bool numpy array

    Examples
    --------
    >>> sample_mask(4, [0, 2]).tolist()
    [True, False, True, False]
    """
    mask = np.zeros(n, dtype=bool)
    mask[np.asarray(idx, dtype=np.int64)] = True
    return mask


class Result(ABC):
    """Base of manifill's results (see the module docstring).

    A subclass has the attributes ``values`` and ``report``, sets
    :attr:`point_ndim` (or overrides it as a property) and implements
    :meth:`masks`, :meth:`to_pyvista` and :meth:`to_meshio` (abstract here);
    :meth:`fields` and :meth:`point_data` follow.
    """

    #: Number of leading axes of ``values`` that index points (1 for vertices, 3 for voxels).
    point_ndim = 1
    #: set by every subclass (a dataclass field each)
    values: np.ndarray
    report: dict

    @property
    def field_names(self) -> list[str]:
        """The fields' names: :attr:`names` when set (e.g. the columns of a samples file), else
        ``value, value2, ...``. Files are written with these unless ``names=`` says otherwise."""
        return field_names(getattr(self, "names", None), self.fields().shape[-1])

    def __repr__(self):
        """One short paragraph: what ran, on what, each field's range (and std's), the time."""
        X = self.fields()
        p = X.shape[-1]
        names = self.field_names
        std = getattr(self, "std", None)
        S = None if std is None else (std if std.ndim == X.ndim else std[..., None])
        report = self.report or {}
        what = report.get("method")
        if what and report.get("curve_values"):
            what += f", {report['curve_values']} curves"
        if what and report.get("preset"):
            what = f"{report['preset']} ({what})"
        head = f"<{type(self).__name__}: {what or 'reconstruction'} on {self._domain()}, {p} field{'s' * (p > 1)}"
        lines = [head]
        width = max([len(n) for n in names[:REPR_FIELDS]], default=0)
        for j, name in enumerate(names[:REPR_FIELDS]):
            col = X[..., j]
            finite = col[np.isfinite(col)]
            rng = f"[{finite.min():.4g}, {finite.max():.4g}]" if finite.size else "all NaN"
            nan = int(col.size - finite.size)
            line = f"  {name:<{width}}  {rng}" + (f", {nan:,} NaN" if nan else "")
            if S is not None:
                sd = S[..., j][np.isfinite(S[..., j])]
                line += f"  std [{sd.min():.3g}, {sd.max():.3g}]" if sd.size else ""
            lines.append(line)
        if p > REPR_FIELDS:
            lines.append(f"  ... and {p - REPR_FIELDS} more")
        seconds = report.get("seconds", {}).get("total") if isinstance(report.get("seconds"), dict) else None
        if seconds is not None:
            lines.append(f"  {seconds:.3g} s")
        return "\n".join(lines) + ">"

    def _domain(self):
        """The domain in a few words, for the repr (e.g. ``40,962 vertices, 100 samples``)."""
        return f"{int(np.prod(self.fields().shape[:-1])):,} points"

    def save(self, path: str | os.PathLike[str], names: Sequence[str] | None = None) -> Path:
        """Write the result to ``path``, in the format its extension names (any that ``manifill`` writes).

        Parameters
        ----------
        path : str or path-like
            E.g. ``out.vtp``, ``out.ply``, ``out.vtu`` (tets), ``out.vti`` (voxels), ``out.csv``.
        names : list of str, optional
            One name per field (default :attr:`field_names`).

        Returns
        -------
        pathlib.Path
            The file written (atomically: nothing is left half-written).
        """
        return _SAVER[0](self, path, self.field_names if names is None else names)

    def sample(self, count: int, *, seed: int = 0) -> np.ndarray:
        """Draws of the field from its fitted posterior (``method='gp'``), for propagating the uncertainty onwards.

        Each draw is a whole field, consistent with the samples (equal to them where they were observed
        exactly) and as uncertain as :attr:`std` says: their spread over many draws is the std.

        Parameters
        ----------
        count : int
            How many draws.
        seed : int, optional
            The same seed gives the same draws.

        Returns
        -------
        numpy array
            Shaped like :attr:`values` with one more axis, the draws last (as scikit-learn's ``sample_y``).

        Raises
        ------
        OptionError
            Without a fitted probability model, or for a count below 1.
        """
        count = int(count)
        if count < 1:
            raise OptionError(f"count={count} draws: pass 1 or more")
        return self._draws(count, seed)

    def _draws(self, count, seed):
        """The draws of :meth:`sample` (a result with a fitted probability model overrides this)."""
        raise OptionError("this result has no fitted probability model to draw from; use method='gp'")

    @overload
    def gradient(self, at: Literal["vertices", "cells"] = ..., *, return_std: Literal[False] = ..., draws: int = ...,
                 seed: int = ...) -> np.ndarray: ...
    @overload
    def gradient(self, at: Literal["vertices", "cells"] = ..., *, return_std: Literal[True], draws: int = ...,
                 seed: int = ...) -> tuple[np.ndarray, np.ndarray]: ...
    @overload
    def gradient(self, at: Literal["vertices", "cells"] = ..., *, return_std: bool, draws: int = ...,
                 seed: int = ...) -> np.ndarray | tuple[np.ndarray, np.ndarray]: ...

    def gradient(self, at: Literal["vertices", "cells"] = "vertices", *, return_std: bool = False, draws: int = 100,
                 seed: int = 0) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """The gradient of every field (of its piecewise-linear interpolant), e.g. a conduction velocity's inverse.

        Parameters
        ----------
        at : {'vertices', 'cells'}, optional
            ``vertices``: per vertex (or voxel), the cells' gradients weighted by their areas or volumes (on a
            surface, the part tangent to it); ``cells``: per triangle or tetrahedron, exact for linear fields.
        return_std : bool, optional
            Also the gradient's std per component, from ``draws`` posterior draws (:meth:`sample`:
            ``method='gp'`` only; a Monte Carlo estimate, relative error about ``1 / sqrt(2 draws)``).
        draws, seed : int, optional

        Returns
        -------
        numpy array
            ``values``' shape with a last axis of 3 (for a field ``(n,)``: ``(n, 3)``); its magnitude is
            ``np.linalg.norm(g, axis=-1)``. With ``return_std``, ``(gradient, std)`` alike.
        """
        if at not in ("vertices", "cells"):
            raise OptionError(f"at={at!r} is not 'vertices' or 'cells'; pass one of those")
        g = self._gradient(self.values, at)
        if not return_std:
            return g
        D = self.sample(draws, seed=seed)  # values' shape + (draws,)
        flat = D.reshape(D.shape[:self.point_ndim] + (-1,))
        G = self._gradient(flat, at)  # (..., fields * draws, 3)
        G = G.reshape(G.shape[:-2] + D.shape[self.point_ndim:] + (3,))
        return g, np.std(G, axis=-2, ddof=1)

    def gradient_data(self, names: Sequence[str] | None = None, *, vector: bool = True) -> dict[str, np.ndarray]:
        """The fields' gradients per point, named as files hold them: ``grad_<name>`` (3-vectors) or
        ``grad_<name>_x``, ``_y``, ``_z`` (``vector=False``), and ``grad_<name>_norm``, for each field."""
        names = self.field_names if names is None else field_names(names, self.fields().shape[-1])
        G = self.gradient()
        if G.ndim == self.values.ndim + 1 and self.values.ndim == self.point_ndim:
            G = G[..., None, :]  # one field: its axis put back
        out = {}
        for j, name in enumerate(names):
            g = G[..., j, :]
            if vector:
                out[f"grad_{name}"] = g
            else:
                out.update({f"grad_{name}_{c}": g[..., i] for i, c in enumerate("xyz")})
            out[f"grad_{name}_norm"] = np.linalg.norm(g, axis=-1)
        return out

    def _gradient(self, X, at):
        """The gradient of the fields ``X`` (points first) where :meth:`gradient` says (a domain with cells
        overrides this)."""
        raise OptionError("this result's domain has no cells to take a gradient on")

    def fields(self) -> np.ndarray:
        """``values`` with a last axis per field, also for a single field.

        Returns
        -------
        numpy array
            Shape ``points + (p,)``: a view of ``values`` when there is one.
        """
        X = self.values
        return X if X.ndim == self.point_ndim + 1 else X[..., None]

    @abstractmethod
    def masks(self) -> dict[str, np.ndarray]:
        """manifill's mask and label arrays of this result, by name (:data:`SAMPLE_MASK`, ...).

        Returns
        -------
        dict of str to numpy array
        """

    def point_data(self, names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
        """The fields and the masks, named as in every output file.

        Parameters
        ----------
        names : list of str, optional
            One name per field (``value``, ``value2``, ... by default).

        Returns
        -------
        dict of str to numpy array
            The fields first, in order, then :meth:`masks`.

        Raises
        ------
        SampleError
            ``names`` not one per field, or repeated.
        """
        X = self.fields()
        names = self.field_names if names is None else field_names(names, X.shape[-1])
        data = dict(zip(names, np.moveaxis(X, -1, 0)))
        return {**data, **self.masks()}

    @abstractmethod
    def to_pyvista(self, names: Sequence[str] | None = None) -> pyvista.DataSet:
        """The domain with every field and mask as a pyvista object (needs the ``[viz]`` extra)."""

    @abstractmethod
    def to_meshio(self, names: Sequence[str] | None = None) -> meshio.Mesh:
        """The domain with every field and mask as a ``meshio.Mesh``."""
