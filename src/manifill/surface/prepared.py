"""What a prepared reconstruction keeps between fields: the value-independent pieces of Steps 2-6.

A :class:`Prepared` is a dictionary of built objects, handed by
:class:`manifill.surface.reconstructor.Reconstructor` to every step it runs, which take
from it what does not depend on the sample values and build it only when it is missing:

- ``"partition"``: Steps 2-3's :class:`~manifill.surface.partition.Partition` (the curves
  through the samples depend on where they are, not on their values);
- ``"fill"``: Steps 5-6's :class:`~manifill.surface.harmonic.HarmonicSolver` on the curve
  vertices (or the samples), with its factorisation or AMG hierarchy;
- ``"curve map"``: Step 4's linear map from sample values to curve values, for the curve
  values that are linear in the data (``hermite``, ``linear``);
- ``"energy"``: the energy methods' solve core (:class:`~manifill.linalg.quadratic.QuadraticSolver`).

A one-shot call (``prepared=None``) builds each piece for itself, as before.
"""

__all__ = ["Prepared", "cached"]


class Prepared(dict):
    """Built pieces by name (see the module docstring)."""


def cached(prepared, key, build):
    """``prepared[key]``, built by ``build()`` the first time; ``build()`` alone when ``prepared`` is None.

    Examples
    --------
    >>> p = Prepared()
    >>> cached(p, "x", lambda: [1]) is cached(p, "x", lambda: [2])
    True
    >>> cached(None, "x", lambda: 3)
    3
    """
    if prepared is None:
        return build()
    if key not in prepared:
        prepared[key] = build()
    return prepared[key]
