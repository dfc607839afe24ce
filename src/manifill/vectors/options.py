"""The vector methods' options: one frozen object with its constraints table (as the scalar methods' groups).

``VectorOptions.build(**keywords)`` checks every keyword against :attr:`VectorOptions.CONSTRAINTS` and the
combinations no vector method takes, in one line each; the command line takes its choices from the table.
"""

from dataclasses import dataclass, fields, replace
from typing import Any

from ..errors import OptionError
from ..validate.constraints import Flag, Kind, Number, OneOf, check_table

__all__ = ["VectorOptions", "VectorMethod", "VECTOR_METHODS", "FITS", "SYMMETRIES", "NORMAL"]

@dataclass(frozen=True)
class VectorMethod:
    """What a vector method is: the power of the connection Laplacian in its energy (None: not an energy), and
    whether it gives a std (a probability model)."""

    order: object
    gives_std: bool = False

    @property
    def energy(self):
        """Whether it minimises an energy of the connection (the fill and the Hodge fits)."""
        return self.order is not None


#: The vector methods by name (the one place their names are told apart): the connection's Dirichlet and
#: biharmonic energies, and its Matérn field.
VECTOR_METHODS = {"biharmonic": VectorMethod(2), "harmonic": VectorMethod(1), "gp": VectorMethod(None, True)}
#: The constrained fits: a potential's gradient, a stream function's rotated gradient.
FITS = ("curl-free", "divergence-free")
#: The symmetries: 1 an arrow, 2 a line (no sign), 4 a cross.
SYMMETRIES = (1, 2, 4)
#: What a sample's normal part beyond a tenth of its length gets: refused, or dropped.
NORMAL = ("refuse", "drop")


@dataclass(frozen=True, kw_only=True)
class VectorOptions:
    """Every option of a vector reconstruction, checked once (``VectorOptions.build(**keywords)``).

    Attributes
    ----------
    method : {'biharmonic', 'harmonic', 'gp'}
        The connection's biharmonic or Dirichlet energy, or its Matérn field (a mean and a std).
    symmetry : {1, 2, 4}
        Arrows, lines (no sign) or crosses.
    fit : {None, 'curl-free', 'divergence-free'}
        A potential's gradient or a stream function's rotated gradient fitted to the arrows.
    bounds : bool or float
        True: no magnitude above the samples' largest; a number: that magnitude; False: none.
    smoothing : None, float >= 0 or 'auto'
        Noisy arrows: the energy weighed against the squared misfit.
    normal : {'refuse', 'drop'}
        A sample more than a tenth normal to the surface: refused, or its normal part dropped.
    solver : {'auto', 'direct', 'amg', 'iterate'}
        The solve's backend.
    max_distance : float or None
        Sample positions farther than this from the surface are refused.
    gp : dict or None
        ``method='gp'``: ``range``, ``sigma`` and ``noise``.
    """

    method: str = "biharmonic"
    symmetry: int = 1
    fit: str | None = None
    bounds: bool | float = True
    smoothing: float | str | None = None
    normal: str = "refuse"
    solver: str = "auto"
    max_distance: float | None = None
    gp: dict | None = None

    CONSTRAINTS = {"method": [OneOf(*VECTOR_METHODS)], "symmetry": [OneOf(*SYMMETRIES)],
                   "fit": [None, OneOf(*FITS)], "bounds": [Flag(), Number(lo=0, lo_open=True)],
                   "smoothing": [None, OneOf("auto"), Number(lo=0)], "normal": [OneOf(*NORMAL)],
                   "solver": [OneOf("auto", "direct", "amg", "iterate")],
                   "max_distance": [None, Number(lo=0, lo_open=True)],
                   "gp": [None, Kind((dict,), "a dict of range, sigma and noise")]}

    @classmethod
    def build(cls, options: "VectorOptions | None" = None, **keywords: Any) -> "VectorOptions":
        """The options from ``options`` (or the defaults) with ``keywords`` changed, checked."""
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(keywords) - names)
        if unknown:
            raise OptionError(f"{unknown[0]}= is not an option of vector fields; pass one of "
                              f"{', '.join(sorted(names))}")
        out = replace(options if options is not None else cls(), **keywords)
        out.validate()
        return out

    @property
    def kind(self) -> VectorMethod:
        """The :class:`VectorMethod` of :attr:`method`."""
        return VECTOR_METHODS[self.method]

    def validate(self) -> None:
        """Check every option against :attr:`CONSTRAINTS` and the combinations no method takes."""
        check_table(self, self.CONSTRAINTS)
        if self.fit is not None and (self.symmetry != 1 or not self.kind.energy):
            raise OptionError(f"fit={self.fit!r} fits arrows (symmetry=1) with an energy method; drop fit= or pass "
                              f"method='biharmonic'")
        if self.smoothing is not None and (not self.kind.energy or self.fit is not None):
            raise OptionError("smoothing= is for the vector fill (no fit=); the gp takes gp={'noise': variance}")
        if self.gp is not None and not self.kind.gives_std:
            raise OptionError("gp= options are for method='gp'; drop them or pass method='gp'")
