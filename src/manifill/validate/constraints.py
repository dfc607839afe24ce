"""What each option may be, written once: the constraints tables of the option groups and their one check.

Every option group (:class:`manifill.surface.options.FillOptions` and its siblings, :class:`manifill.GPOptions`)
has a table ``CONSTRAINTS``, option name -> the forms it takes (a value passes when one of them holds). The groups'
``validate`` checks it (:func:`check_table`), the command line reads its choices and help from it
(:func:`choices`, :func:`describe`), and a test walks every table with a value none of the forms takes
(:func:`invalid_value`). Checks that need the data (bounds against the samples, the number of fields) stay where the
data is.

Examples
--------
>>> table = {"solver": [OneOf("auto", "direct")], "tol": [None, Number(lo=0, lo_open=True)]}
>>> check("tol", 1e-8, table["tol"])
1e-08
>>> describe(table["tol"])
'None or a number > 0'
>>> check("solver", "lu", table["solver"])
Traceback (most recent call last):
...
manifill.errors.OptionError: solver='lu' is not 'auto' or 'direct'; pass one of those
>>> check("tol", -1, table["tol"])
Traceback (most recent call last):
...
manifill.errors.OptionError: tol=-1 is not a number > 0; pass one, or leave it out
"""

import math
from numbers import Integral, Real

import numpy as np

from ..errors import OptionError

__all__ = ["OneOf", "Number", "Flag", "Pair", "Kind", "check", "check_table", "describe", "choices",
           "invalid_value"]


class OneOf:
    """One of a closed set of values (strings, or whole numbers such as the gp's ``alpha``)."""

    def __init__(self, *values):
        self.values = tuple(values)

    def holds(self, v):
        return (isinstance(v, str) or not isinstance(v, (bool, np.bool_))) and any(
            type(v) is type(a) and v == a or (isinstance(a, int) and isinstance(v, Integral) and v == a)
            for a in self.values)

    def describe(self):
        return _either([repr(a) for a in self.values])


class Number:
    """A finite real (or whole, ``integer``) number within ``[lo, hi]`` (an end open with ``lo_open``/``hi_open``)."""

    def __init__(self, lo=None, hi=None, *, lo_open=False, hi_open=False, integer=False):
        self.lo, self.hi, self.lo_open, self.hi_open, self.integer = lo, hi, lo_open, hi_open, integer

    def holds(self, v):
        if isinstance(v, (bool, np.bool_, str)) or not isinstance(v, Integral if self.integer else Real):
            return False
        x = float(v)
        if not math.isfinite(x):
            return False
        if self.lo is not None and (x < self.lo or (self.lo_open and x == self.lo)):
            return False
        return self.hi is None or not (x > self.hi or (self.hi_open and x == self.hi))

    def describe(self):
        kind = "a whole number" if self.integer else "a number"
        ends = []
        if self.lo is not None:
            ends.append(f"{'>' if self.lo_open else '>='} {self.lo:g}")
        if self.hi is not None:
            ends.append(f"{'<' if self.hi_open else '<='} {self.hi:g}")
        return kind + (" " + " and ".join(ends) if ends else "")


class Flag:
    """True or False."""

    def holds(self, v):
        return isinstance(v, (bool, np.bool_))

    def describe(self):
        return "True or False"


class Pair:
    """A ``(lo, hi)`` pair (its ends, each None, a number or one per field, are checked against the data)."""

    def holds(self, v):
        return not isinstance(v, (str, bytes, dict)) and hasattr(v, "__len__") and len(v) == 2

    def describe(self):
        return "a (lo, hi) pair"


class Kind:
    """An instance of one of ``types`` (a dict, a file's path, an array ...), described in words."""

    def __init__(self, types, words):
        self.types, self.words = tuple(types), words

    def holds(self, v):
        return isinstance(v, self.types) and not isinstance(v, (bool, np.bool_))

    def describe(self):
        return self.words


def _either(words):
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def _holds(form, v):
    return v is None if form is None else form.holds(v)


def describe(forms):
    """The forms of one option in words (``"None or a number > 0"``)."""
    return _either(["None" if f is None else f.describe() for f in forms])


def check(name, value, forms, owner=""):
    """``value`` when one of ``forms`` holds, else an :class:`~manifill.errors.OptionError` naming the option
    (``owner`` before it, e.g. ``"gp "``) and what it takes."""
    if any(_holds(f, value) for f in forms):
        return value
    shown = [f for f in forms if f is not None]
    fix = ("pass one" if len(shown) == 1 and not isinstance(shown[0], OneOf) else "pass one of those") + (
        ", or leave it out" if None in forms else "")
    raise OptionError(f"{owner}{name}={value!r} is not {describe(shown)}; {fix}")


def check_table(obj, table, owner=""):
    """Check every attribute of ``obj`` named in ``table`` (an option group's ``validate``)."""
    for name, forms in table.items():
        check(name, getattr(obj, name), forms, owner)


def choices(forms):
    """The closed set of one option (its :class:`OneOf`), for the command line's ``choices``."""
    for f in forms:
        if isinstance(f, OneOf):
            return f.values
    raise KeyError("no closed set among these forms")


#: Values tried in turn by :func:`invalid_value`: one of them fails every form manifill's tables use.
_CANDIDATES = ("not-an-option", -7, 0.5, -0.5, math.nan, 10**9, object())


def invalid_value(forms):
    """A value none of ``forms`` takes (for the test that tries one for every option)."""
    for v in _CANDIDATES:
        if not any(_holds(f, v) for f in forms):
            return v
    raise ValueError(f"every candidate is valid for {describe(forms)}")
