"""numpydoc's validation of every public name the API reference lists, and of their public methods.

Run from the repository's root: ``python docs/numpydoc_report.py [CHECK ...]``. It prints one line per problem
(``name: CODE message``) and exits 1 when there is any. Without arguments it runs the checks that say a docstring
is wrong or missing, not those of style:

- GL08: no docstring
- PR01: a parameter of the signature is not documented
- PR02: a documented parameter is not in the signature
- PR03: the parameters are documented in another order than the signature's
- GL02, GL03: blank lines at the start or end of the docstring
- GL06, GL07: an unknown section, or sections out of numpydoc's order
- RT01: no Returns section
- YD01: no Yields section

``python docs/numpydoc_report.py all`` runs every check numpydoc has. The documentation's build runs none of them
(``numpydoc_validation_checks`` is empty in conf.py), so a docstring that fails here still builds.
"""

import importlib
import inspect
import sys

from numpydoc.validate import validate

MODULES = ("manifill", "manifill.adapters.mne", "manifill.adapters.sklearn", "manifill.adapters.globe")
DEFAULT_CHECKS = {"GL08", "PR01", "PR02", "PR03", "GL02", "GL03", "GL06", "GL07", "RT01", "YD01"}


def public_names():
    """``(qualified name for numpydoc, object)`` of every ``__all__`` name and its classes' public methods."""
    for module_name in MODULES:
        module = importlib.import_module(module_name)
        for name in module.__all__:
            obj = getattr(module, name)
            if not (inspect.isclass(obj) or callable(obj)):
                continue  # constants: a ``#:`` comment, not a docstring
            where = f"{obj.__module__}.{obj.__qualname__}"
            yield f"{module_name}.{name}", where, obj
            if inspect.isclass(obj) and not issubclass(obj, BaseException):
                for member, value in vars(obj).items():
                    if member.startswith("_") or not (inspect.isfunction(value) or isinstance(value, property)):
                        continue
                    yield f"{module_name}.{name}.{member}", f"{where}.{member}", value


def main(argv):
    checks = None if argv[:1] == ["all"] else set(argv) or DEFAULT_CHECKS
    problems = 0
    for shown, where, _ in public_names():
        try:
            result = validate(where)
        except Exception as exc:  # numpydoc could not even parse it
            print(f"{shown}: ERROR {type(exc).__name__}: {exc}")
            problems += 1
            continue
        for code, message in result["errors"]:
            if checks is None or code in checks:
                print(f"{shown}: {code} {message}")
                problems += 1
    print(f"{problems} problem(s)", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
