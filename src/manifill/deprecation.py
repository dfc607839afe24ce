"""Public names renamed or moved, kept one release with a ``DeprecationWarning``: one helper for every module.

A module lists its old names, each with the new one as ``"package.module:name"``, and sets
``__getattr__ = renamed(__name__, {...})``; reading an old name warns once per place and gives the new object.
The closing notes of a release list every entry, and the next release deletes them.

Examples
--------
>>> import warnings
>>> getattr_ = renamed("manifill.example", {"OLD": "manifill.tolerances:TOL"})
>>> with warnings.catch_warnings(record=True) as w:
...     warnings.simplefilter("always")
...     tol = getattr_("OLD")
>>> from manifill.tolerances import TOL
>>> tol is TOL, str(w[0].message)
(True, 'manifill.example.OLD is now manifill.tolerances.TOL; the old name goes in the next release')
"""

import importlib
import warnings

__all__ = ["renamed"]


def renamed(module, table):
    """A module ``__getattr__`` for ``table`` (old name -> ``"module:new name"``) of the module named ``module``."""

    def __getattr__(name):
        if name not in table:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        where, new = table[name].split(":")
        warnings.warn(f"{module}.{name} is now {where}.{new}; the old name goes in the next release",
                      DeprecationWarning, stacklevel=2)
        return getattr(importlib.import_module(where), new)

    return __getattr__
