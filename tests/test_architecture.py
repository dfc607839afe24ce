"""The shape of the package: layers, no import cycle, no private name used across modules, modest modules.

Read from the source with :mod:`ast` (nothing imported), so a violation names the file and line.
"""

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "src" / "manifill"
ROOT = PKG.parent.parent
MAX_LINES = 500

#: Lower layers never import higher ones at module level (imports inside functions may reach up
#: for optional presentation: a result's ``to_pyvista``, a mask's file name).
LAYERS = ["base", "mesh", "linalg", "surface", "solid", "io", "viz", "demo", "cli", "cluster"]
BASE = {"errors", "tolerances", "validate", "memory", "progress", "results", "report", "__init__", "__main__"}


def modules():
    for path in sorted(PKG.rglob("*.py")):
        parts = path.relative_to(PKG).with_suffix("").parts
        yield path, ".".join(parts)


def layer(name):
    top = name.split(".")[0]
    if top in BASE or name == "__init__":
        return "base"
    return top


def package_of(name, path):
    parts = name.split(".")
    return parts if path.name == "__init__.py" else parts[:-1]


def imports(path, name):
    """(line, target module, imported names, at module level) for every manifill import in one file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    top_level = {id(n) for n in tree.body}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package_of(name, path)
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
    """The modules an import statement loads: ``from pkg import mod`` names modules."""
    out = []
    for nm in names:
        sub = f"{target}.{nm}" if target else nm
        if sub in known:
            out.append(sub)
    if not out or target in known:
        out.append(target)
    return out


MODS = dict((n, p) for p, n in modules())
KNOWN = set(MODS) | {n.rsplit(".", 1)[0] for n in MODS if n.endswith("__init__")}


def norm(m):
    return m[: -len(".__init__")] if m.endswith(".__init__") else ("" if m == "__init__" else m)


def test_no_private_names_across_modules():
    bad = []
    for name, path in MODS.items():
        for line, target, names, _ in imports(path, name):
            if norm(name) == target:
                continue
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private:
                bad.append(f"{path.relative_to(ROOT)}:{line} imports {', '.join(private)} from manifill.{target}")
    assert not bad, "\n".join(bad)


def graph(module_level_only=True):
    known = {norm(n) for n in MODS}
    edges = {norm(n): set() for n in MODS}
    for name, path in MODS.items():
        for _, target, names, top in imports(path, name):
            if module_level_only and not top:
                continue
            for t in resolve(target, names, known):
                if t != norm(name) and t in known:
                    edges[norm(name)].add(t)
    return edges


def test_no_import_cycle():
    edges = graph()
    state, stack, cycles = {}, [], []

    def visit(u):
        state[u] = 1
        stack.append(u)
        for v in sorted(edges[u]):
            if state.get(v) == 1:
                cycles.append(" -> ".join(stack[stack.index(v):] + [v]))
            elif v not in state:
                visit(v)
        stack.pop()
        state[u] = 2

    for u in sorted(edges):
        if u not in state:
            visit(u)
    assert not cycles, "\n".join(cycles)


def test_layers_import_downwards():
    bad = []
    for u, targets in graph().items():
        if u in ("", "__main__") or u.endswith("__init__"):
            continue
        lu = LAYERS.index(layer(u or "__init__"))
        for v in targets:
            if v == "":
                continue
            if LAYERS.index(layer(v)) > lu and u != "":
                bad.append(f"manifill.{u} ({layer(u)}) imports manifill.{v} ({layer(v)}) at module level")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("name", sorted(MODS))
def test_modules_stay_small(name):
    lines = MODS[name].read_text().count("\n")
    assert lines <= MAX_LINES, f"{MODS[name].relative_to(ROOT)} has {lines} lines; split it by concept"


def test_architecture_page_names_every_module():
    page = (ROOT / "docs" / "ARCHITECTURE.md").read_text()
    missing = [n for n in MODS if not n.endswith("__init__") and n != "__main__"
               and n.rsplit(".", 1)[-1] + ".py" not in page]
    assert not missing, f"docs/ARCHITECTURE.md does not mention: {', '.join(missing)}"
