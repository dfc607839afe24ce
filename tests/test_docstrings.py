"""Every public name documents every parameter (numpydoc's ``Parameters``; a dataclass's fields under
``Attributes``), so ``help()`` and the API reference say what each takes; ``reconstruct`` documents every option."""

import dataclasses
import importlib
import inspect
import re

import pytest

import manifill
from manifill.surface.options import OPTION_NAMES

ADAPTERS = ["manifill.adapters.sklearn", "manifill.adapters.mne", "manifill.adapters.globe"]


def documented(doc, title):
    """The names a numpydoc section lists (``a, b : type`` lines at the section's indentation)."""
    doc = inspect.cleandoc(doc or "")
    m = re.search(rf"^{title}\n-{{3,}}\n(.*?)(?=^\S[^\n]*\n-{{3,}}\n|\Z)", doc, re.M | re.S)
    names = set()
    for line in (m.group(1).splitlines() if m else []):
        if line and not line.startswith(" "):
            names.update(n.strip().lstrip("*") for n in line.split(" : ")[0].split(","))
    return names


def public():
    out = [(f"manifill.{n}", getattr(manifill, n)) for n in manifill.__all__]
    for mod in ADAPTERS:
        try:
            m = importlib.import_module(mod)
        except ImportError:  # its extra is not installed
            continue
        out += [(f"{mod}.{n}", getattr(m, n)) for n in m.__all__]
    return [(name, obj) for name, obj in out if callable(obj) and not (inspect.isclass(obj)
                                                                      and issubclass(obj, BaseException))]


def missing(obj):
    if inspect.isclass(obj) and obj.__init__ is object.__init__:
        return []
    params = [p for p in inspect.signature(obj).parameters.values() if p.name not in ("self", "cls")]
    have = documented(obj.__doc__, "Parameters")
    if dataclasses.is_dataclass(obj):
        have |= documented(obj.__doc__, "Attributes")
    if "keywords" not in have and set(OPTION_NAMES) <= have:  # every option of **keywords named one by one
        have.add("keywords")
    return [p.name for p in params if p.name not in have]


@pytest.mark.parametrize("name, obj", public(), ids=[n for n, _ in public()])
def test_every_parameter_is_documented(name, obj):
    assert obj.__doc__, f"{name} has no docstring"
    assert not missing(obj), f"{name} does not document {missing(obj)}"


def test_reconstruct_documents_every_option_and_point_clouds():
    have = documented(manifill.reconstruct.__doc__, "Parameters")
    assert set(OPTION_NAMES) <= have, sorted(set(OPTION_NAMES) - have)
    assert "None for a point cloud" in manifill.reconstruct.__doc__


def test_the_check_sees_a_missing_parameter():
    def f(a, b, *, c=1):
        """One line.

        Parameters
        ----------
        a, b : int
        """

    assert missing(f) == ["c"]
