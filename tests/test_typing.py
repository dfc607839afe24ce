"""The package type-checks (mypy, the [tool.mypy] of pyproject.toml), and its public API's annotations say what a
user's code gets back: a checker catches a result used as the wrong type. Every public function and method is
annotated (each parameter and the return), so that a checker sees every call into manifill."""

import importlib
import inspect
import re
import subprocess
import sys
from pathlib import Path

import pytest

import manifill

ROOT = Path(__file__).resolve().parents[1]
#: The adapters' modules as the API reference documents them (each needs its extra: one not installed is skipped).
ADAPTERS = re.findall(r"^\.\. currentmodule:: (manifill\.adapters\.\w+)$", (ROOT / "docs" / "api.rst").read_text(),
                      re.M)


def _mypy(*args):
    pytest.importorskip("mypy")
    return subprocess.run([sys.executable, "-m", "mypy", "--no-incremental", *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=600)


USER = ("import manifill\n"
        "V, F = manifill.read_mesh('m.ply')\n"
        "r = manifill.reconstruct(V, F, [0, 1], [0.0, 1.0])\n"
        "ok: manifill.Reconstruction = r\n"
        "wrong: int = manifill.reconstruct(V, F, [0, 1], [0.0, 1.0])\n")


@pytest.fixture(scope="module")
def checked(tmp_path_factory):
    """One mypy run over the package and a user's script beside it (two runs took 27 s each)."""
    user = tmp_path_factory.mktemp("user") / "user.py"
    user.write_text(USER)
    done = _mypy("src/manifill", str(user))
    return done, [line for line in done.stdout.splitlines() if ": error:" in line]


def test_the_package_type_checks(checked):
    _, errors = checked
    assert not [e for e in errors if not e.split(":")[0].endswith("user.py")], "\n".join(errors)[-3000:]


def test_a_users_wrong_use_of_a_result_is_caught(checked):
    done, errors = checked
    mine = [e for e in errors if e.split(":")[0].endswith("user.py")]
    assert len(mine) == 1 and 'user.py:5: error: Incompatible types in assignment (expression has type ' \
                               '"Reconstruction", variable has type "int")' in mine[0], done.stdout


def public_functions():
    """``(name, function)`` for every public function, and every public method, classmethod, staticmethod, property
    and ``__init__`` of every public class, of ``manifill.__all__`` and the adapters' ``__all__``; each once (where it
    is defined), manifill's own only (not what a class inherits from scikit-learn)."""
    modules = [manifill]
    for name in ADAPTERS:
        try:
            modules.append(importlib.import_module(name))
        except ImportError:  # its extra is not installed
            continue
    found = {}
    for mod in modules:
        for name in mod.__all__:
            obj = getattr(mod, name)
            if not inspect.isclass(obj):
                if callable(obj):
                    found.setdefault(obj, f"{mod.__name__}.{name}")
                continue
            for attr, raw in inspect.getmembers_static(obj):
                if attr.startswith("_") and attr != "__init__":
                    continue
                fn = raw.__func__ if isinstance(raw, (classmethod, staticmethod)) else (
                    raw.fget if isinstance(raw, property) else raw)
                if inspect.isfunction(fn):
                    found.setdefault(fn, f"{mod.__name__}.{name}.{attr}")
    return [(name, fn) for fn, name in found.items() if (getattr(fn, "__module__", None) or "").startswith("manifill")]


def unannotated(fn):
    """The parameters of ``fn`` without an annotation (``self`` and ``cls`` aside), and ``return`` if it has none
    (an ``__init__`` returns None and may say so or not)."""
    sig = inspect.signature(fn)
    missing = [p.name for p in sig.parameters.values()
               if p.name not in ("self", "cls") and p.annotation is inspect.Parameter.empty]
    if sig.return_annotation is inspect.Signature.empty and fn.__name__ != "__init__":
        missing.append("return")
    return missing


def test_adapters_are_listed():
    assert {"manifill.adapters.mne", "manifill.adapters.sklearn", "manifill.adapters.globe"} <= set(ADAPTERS)


def test_the_public_api_is_annotated():
    bad = [f"{name}: {', '.join(missing)}" for name, fn in public_functions() if (missing := unannotated(fn))]
    assert not bad, "not annotated (parameters, or return):\n" + "\n".join(bad)


def test_the_annotation_check_sees_what_is_missing():
    def f(a: int, b, *, c: str = "", **rest) -> int:
        return a

    class C:
        def __init__(self, x):
            self.x = x

        @property
        def y(self):
            return self.x

    assert unannotated(f) == ["b", "rest"]
    assert unannotated(C.__init__) == ["x"] and unannotated(C.y.fget) == ["return"]
    assert ("manifill.reconstruct", manifill.reconstruct) in public_functions()
