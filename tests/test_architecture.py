"""The shape of the package: layers, no import cycle, no private name used across modules, modest modules.

Read from the source with :mod:`ast` (nothing imported), so a violation names the file and line.
Every import counts, wherever it is: at module level or inside a function.
"""

import ast
import io
import tokenize
from functools import lru_cache
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "src" / "manifill"
ROOT = PKG.parent.parent
MAX_LINES = 450  # below the cap the old modules grew to, so the cap is not the design
#: lines of code in one function or method (docstrings, blank and comment-only lines not counted)
MAX_FUNCTION_LINES = 100
#: parameters of one function or method (self/cls not counted; *args and **kwargs one each)
MAX_PARAMETERS = 12

#: Lower layers never import higher ones, at module level or inside a function. ``top`` is the
#: package's ``__init__.py`` (the flat public API, which re-exports every layer) and ``__main__.py``:
#: no module imports them.
LAYERS = ["base", "mesh", "linalg", "surface", "vectors", "solid", "io", "viz", "demo", "adapters", "cli", "cluster",
          "top"]
BASE = {"errors", "tolerances", "validate", "memory", "progress", "results", "report", "version", "deprecation"}
TOP = {"", "__main__", "console"}

#: The only packages a function may import inside its body (lazily): optional extras, or slow to import
#: and needed by few calls. Everything else (numpy, scipy, the standard library, manifill itself)
#: is imported at module level. One line each: why it stays lazy.
LAZY_IMPORTS = {
    "pyvista": "the [viz] extra; VTK takes about a second to import",
    "vtk": "pyvista's VTK, same reason",
    "matplotlib": "the [bench] figures only; slow to import",
    "igl": "the [volume] extra (libigl)",
    "tetgen": "the [volume] extra, run in a child process",
    "nibabel": "the [neuro] extra (GIfTI, FreeSurfer, MGH)",
    "h5py": "the [series] extra (XDMF + HDF5 series)",
    "dask": "the [batch] extra",
    "distributed": "the [batch] extra",
    "robust_laplacian": "the [robust] extra",
    "pypardiso": "the [fast] extra (Intel MKL Pardiso, x86-64 only)",
    "sksparse": "the [cholmod] extra (scikit-sparse; builds against SuiteSparse)",
    "threadpoolctl": "optional ([cholmod], [all]): BLAS held to one thread while a selected inversion runs",
    "trimesh": "never imported by manifill for its own use; a user's object is recognised by its type's module",
    "lz4": "optional: only a VTK XML file compressed with LZ4 needs it",
    "psutil": "installed with distributed only (a batch job's peak memory)",
    "meshio": "a dependency, but ~0.2 s to import; only meshio's formats and objects need it",
    "tqdm": "a dependency, but it pulls in more than a quiet run needs; only a shown step bar needs it",
    "pyamg": "a dependency, but its __init__ loads all of pyamg (~0.1 s); only AMG solves and a graph search need it",
    "xarray": "the [xarray] extra; the command line loads the globe adapter, which needs xarray only when run",
    "pandas": "the [xarray] extra (a CSV of stations read by `manifill globe`)",
}

#: Functions allowed more than MAX_PARAMETERS parameters: "path/from/src/manifill.py:qualname" -> reason.
#: (Empty: a documented public entry point that forwards an options object may be added, with its reason.)
MANY_PARAMETERS = {}

#: Standard-library modules and names newer than requires-python (3.10): imported only with a fallback
#: (inside ``try:`` ... ``except ImportError``/``ModuleNotFoundError``, or under a ``sys.version_info`` test).
NEWER_STDLIB = {"tomllib": "3.11", "wsgiref.types": "3.11"}
NEWER_NAMES = {
    "typing": {"Self", "LiteralString", "Never", "assert_never", "assert_type", "reveal_type", "TypeVarTuple",
               "Unpack", "Required", "NotRequired", "dataclass_transform", "override", "get_overloads"},
    "enum": {"StrEnum", "ReprEnum", "verify", "EnumCheck", "FlagBoundary", "member", "nonmember"},
    "asyncio": {"TaskGroup", "timeout", "Runner"},
    "contextlib": {"chdir"},
    "datetime": {"UTC"},
    "itertools": {"batched"},
}


def modules():
    for path in sorted(PKG.rglob("*.py")):
        parts = path.relative_to(PKG).with_suffix("").parts
        yield path, ".".join(parts)


def layer(name):
    if name in TOP or name in ("__init__", "__main__"):
        return "top"
    top = name.split(".")[0]
    return "base" if top in BASE else top


@lru_cache(maxsize=None)
def parse(path):
    return ast.parse(path.read_text(), filename=str(path))


def where(path, line):
    return f"{path.relative_to(ROOT)}:{line}"


def in_functions(tree):
    """(node, enclosing function or None) for every node of a module."""
    stack = [(tree, None)]
    while stack:
        node, fn = stack.pop()
        yield node, fn
        inner = node if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)) else fn
        stack.extend((child, inner) for child in ast.iter_child_nodes(node))


def imports(path, name):
    """(line, target module, imported names, at module level) for every manifill import in one file."""
    tree = parse(path)
    top_level = {id(n) for n in tree.body}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")[:-1]  # the package (an __init__'s name ends in __init__ too)
                base = base[: len(base) - (node.level - 1)] if node.level > 1 else base
                target = ".".join(base + ([node.module] if node.module else []))
            elif node.module and node.module.split(".")[0] == "manifill":
                target = node.module[len("manifill"):].lstrip(".")
            else:
                continue
            yield node.lineno, target, [a.name for a in node.names], id(node) in top_level
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "manifill":
                    yield node.lineno, a.name[len("manifill"):].lstrip("."), [], id(node) in top_level


def resolve(target, names, known):
    """The modules an import statement needs: ``from pkg import mod`` names a module; any other name
    (or ``import pkg``) needs ``pkg``'s ``__init__``."""
    out = []
    for nm in names:
        sub = f"{target}.{nm}" if target else nm
        if sub in known:
            out.append(sub)
        elif target in known and target not in out:
            out.append(target)
    if not names and target in known:
        out.append(target)
    return out


MODS = dict((n, p) for p, n in modules())


def norm(m):
    return m[: -len(".__init__")] if m.endswith(".__init__") else ("" if m == "__init__" else m)


KNOWN = {norm(n) for n in MODS}


def test_no_private_names_across_modules():
    bad = []
    for name, path in MODS.items():
        for line, target, names, _ in imports(path, name):
            if norm(name) == target:
                continue
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private:
                bad.append(f"{where(path, line)} imports {', '.join(private)} from manifill.{target}")
    assert not bad, "\n".join(bad)


def graph():
    """module -> {imported module: (path, line, at module level)} over every manifill import."""
    edges = {norm(n): {} for n in MODS}
    for name, path in MODS.items():
        for line, target, names, top in imports(path, name):
            for t in resolve(target, names, KNOWN):
                if t != norm(name) and t in KNOWN:
                    edges[norm(name)].setdefault(t, (path, line, top))
    return edges


def describe(edges, u, v):
    path, line, top = edges[u][v]
    return f"{where(path, line)} manifill.{u or '__init__'} imports manifill.{v or '__init__'}" + (
        "" if top else " (inside a function)")


def test_no_import_cycle():
    edges = graph()
    state, stack, cycles = {}, [], []

    def visit(u):
        state[u] = 1
        stack.append(u)
        for v in sorted(edges[u]):
            if state.get(v) == 1:
                ring = stack[stack.index(v):] + [v]
                cycles.append("cycle " + " -> ".join(m or "__init__" for m in ring) + ":\n    " + "\n    ".join(
                    describe(edges, a, b) for a, b in zip(ring, ring[1:])))
            elif v not in state:
                visit(v)
        stack.pop()
        state[u] = 2

    for u in sorted(edges):
        if u not in state:
            visit(u)
    assert not cycles, "\n".join(dict.fromkeys(cycles))


def test_layers_import_downwards():
    edges = graph()
    bad = []
    for u, targets in edges.items():
        lu = LAYERS.index(layer(u))
        for v in sorted(targets):
            if LAYERS.index(layer(v)) > lu:
                bad.append(f"{describe(edges, u, v)}: layer {layer(u)} below {layer(v)}")
    assert not bad, "\n".join(bad)


def third_party_lazy_imports():
    """(path, line, imported module, its top-level package) for every non-manifill import inside a function."""
    for path in MODS.values():
        for node, fn in in_functions(parse(path)):
            if fn is None or not isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    continue
                mods = [node.module]
            else:
                mods = [a.name for a in node.names]
            for mod in mods:
                if mod.split(".")[0] != "manifill":
                    yield path, node.lineno, mod, mod.split(".")[0]


def test_lazy_imports_are_optional_or_heavy():
    bad = [f"{where(path, line)} imports {mod} inside a function; import it at module level (or, if it is "
           f"optional or slow to import, add {top} to LAZY_IMPORTS with the reason)"
           for path, line, mod, top in third_party_lazy_imports() if top not in LAZY_IMPORTS]
    assert not bad, "\n".join(bad)


def code_lines(path):
    """The numbers of the lines of a file that hold code: not blank, not only a comment, not a docstring."""
    text = path.read_text()
    lines = set()
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type not in (tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT,
                            tokenize.ENDMARKER):
            lines.update(range(tok.start[0], tok.end[0] + 1))
    for node in ast.walk(parse(path)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(
                    first.value.value, str):
                lines.difference_update(range(first.lineno, first.end_lineno + 1))
    return lines


def functions():
    """(path, qualified name, node) for every function and method."""
    for path in MODS.values():
        def walk(node, prefix, path=path):
            for child in ast.iter_child_nodes(node):
                if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    yield path, prefix + child.name, child
                    yield from walk(child, f"{prefix}{child.name}.")
                elif isinstance(child, ast.ClassDef):
                    yield from walk(child, f"{prefix}{child.name}.")
                else:
                    yield from walk(child, prefix)
        yield from walk(parse(path), "")


def test_functions_stay_short():
    bad = []
    for path, qualname, node in functions():
        body = code_lines(path) & set(range(node.lineno, node.end_lineno + 1))
        if len(body) > MAX_FUNCTION_LINES:
            bad.append(f"{where(path, node.lineno)} {qualname} has {len(body)} lines of code (at most "
                       f"{MAX_FUNCTION_LINES}); split it into steps")
    assert not bad, "\n".join(bad)


def parameter_count(node):
    a = node.args
    positional = [p.arg for p in a.posonlyargs + a.args]
    skip = 1 if positional and positional[0] in ("self", "cls") else 0
    return len(positional) - skip + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)


def test_functions_take_few_parameters():
    bad = []
    for path, qualname, node in functions():
        key = f"{path.relative_to(PKG).as_posix()}:{qualname}"
        n = parameter_count(node)
        if n > MAX_PARAMETERS and key not in MANY_PARAMETERS:
            bad.append(f"{where(path, node.lineno)} {qualname} takes {n} parameters (at most {MAX_PARAMETERS}); "
                       f"group them in an options object")
    assert not bad, "\n".join(bad)


def test_many_parameters_allow_list_is_current():
    """Every allow-listed function exists and still needs its exception (no stale entries)."""
    counts = {f"{p.relative_to(PKG).as_posix()}:{q}": parameter_count(n) for p, q, n in functions()}
    stale = [k for k in MANY_PARAMETERS if counts.get(k, 0) <= MAX_PARAMETERS]
    assert not stale, f"remove from MANY_PARAMETERS (gone, or {MAX_PARAMETERS} parameters or fewer): {stale}"


def has_fallback(ancestors):
    """An import guarded by ``try: ... except ImportError`` or by a ``sys.version_info`` test."""
    for parent, child in zip(ancestors, ancestors[1:]):
        if isinstance(parent, ast.Try) and child in parent.body:
            for h in parent.handlers:
                names = [h.type] if not isinstance(h.type, ast.Tuple) else h.type.elts
                if h.type is None or any(isinstance(t, ast.Name) and t.id in (
                        "ImportError", "ModuleNotFoundError", "Exception") for t in names):
                    return True
        if isinstance(parent, ast.If) and "version_info" in ast.unparse(parent.test):
            return True
    return False


def newer_stdlib(node):
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name in NEWER_STDLIB]
    if isinstance(node, ast.ImportFrom) and not node.level and node.module:
        if node.module in NEWER_STDLIB:
            return [node.module]
        return [f"{node.module}.{a.name}" for a in node.names if a.name in NEWER_NAMES.get(node.module, ())]
    return []


def test_newer_standard_library_has_a_fallback():
    """requires-python is 3.10: what the standard library gained since is imported only with a fallback."""
    bad = []
    for path in MODS.values():
        def walk(node, ancestors, path=path):
            for child in ast.iter_child_nodes(node):
                for what in newer_stdlib(child):
                    if not has_fallback(ancestors + [node, child]):
                        bad.append(f"{where(path, child.lineno)} imports {what}, which Python 3.10 lacks; import it "
                                   f"in try/except ImportError with a fallback (e.g. tomli for tomllib)")
                walk(child, ancestors + [node])
        walk(parse(path), [])
    assert not bad, "\n".join(bad)


#: The names ``method=`` takes (the registry's, ``surface/methods/registry.py``). Generic code asks a method
#: object what it can do; only the registry compares these names.
METHOD_NAMES = {"gvf-harmonic", "harmonic", "biharmonic", "triharmonic", "gvf", "rbf", "gp", "auto", "default"}
#: Names that are also other options' values ('auto' a solver, 'harmonic' a report key, 'gvf' a start and a kind of
#: curve values): compared with something named ``method`` only are they a method's name.
AMBIGUOUS = {"auto", "harmonic", "gvf"}
#: Where a variable named ``method`` means something else: Step 4's kind of curve values ('gvf' is the paper's fit).
OTHER_METHODS = {"surface/curve_values.py"}


def _strings(node):
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return {node.value}
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return set().union(*(_strings(e) for e in node.elts)) if node.elts else set()
    return set()


def test_method_names_are_compared_only_in_the_registry():
    bad = []
    for path in MODS.values():
        rel = path.relative_to(PKG).as_posix()
        if rel.startswith("surface/methods/") or rel in OTHER_METHODS:
            continue
        src = path.read_text()
        for node in ast.walk(parse(path)):
            if not isinstance(node, ast.Compare):
                continue
            sides = [node.left] + node.comparators
            about_method = any("method" in (ast.get_source_segment(src, side) or "").lower() for side in sides)
            names = set().union(*(_strings(side) for side in sides)) & METHOD_NAMES
            if names - AMBIGUOUS or (names and about_method):
                bad.append(f"{where(path, node.lineno)}: {ast.get_source_segment(src, node)} (ask the method object: "
                           f"manifill.surface.methods.registry.method_of(name).<capability>)")
    assert not bad, "\n".join(bad)


def test_the_method_name_check_sees_a_comparison():
    src = 'def f(method, name):\n    return method == "gp" or args.method in ("harmonic", "x") or name == "rbf"\n'
    tree = ast.parse(src)
    hits = [n for n in ast.walk(tree) if isinstance(n, ast.Compare)
            and any(_strings(side) & METHOD_NAMES for side in [n.left] + n.comparators)]
    assert len(hits) == 3


@pytest.mark.parametrize("name", sorted(MODS))
def test_modules_stay_small(name):
    lines = MODS[name].read_text().count("\n")
    assert lines <= MAX_LINES, f"{MODS[name].relative_to(ROOT)} has {lines} lines; split it by concept"


def test_architecture_page_names_every_module():
    page = (ROOT / "docs" / "ARCHITECTURE.md").read_text()
    missing = [n for n in MODS if not n.endswith("__init__") and n != "__main__"
               and n.rsplit(".", 1)[-1] + ".py" not in page]
    assert not missing, f"docs/ARCHITECTURE.md does not mention: {', '.join(missing)}"
