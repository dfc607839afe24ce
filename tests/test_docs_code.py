"""The documentation's Python blocks run (each page's blocks in order, in a fresh folder with the demo's two files),
so what the pages show is what the library does."""

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from test_readme import _demo_files

DOCS = Path(__file__).resolve().parents[1] / "docs"
PAGES = sorted(p for p in [*DOCS.glob("*.rst"), *DOCS.glob("guide/*.rst")]
               if ".. code-block:: python" in p.read_text(encoding="utf-8"))


def blocks(text):
    """The ``.. code-block:: python`` blocks of an rst page, dedented."""
    out = []
    for m in re.finditer(r"^\.\. code-block:: python\n((?:[ \t]*:[^\n]*\n)*)\n((?:(?:[ \t]+[^\n]*)?\n)+)", text, re.M):
        lines = m.group(2).splitlines()
        indent = min(len(ln) - len(ln.lstrip()) for ln in lines if ln.strip())
        out.append("\n".join(ln[indent:] for ln in lines))
    return out


def test_the_pages_have_code():
    assert len(PAGES) >= 8 and sum(len(blocks(p.read_text(encoding="utf-8"))) for p in PAGES) >= 15


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(DOCS).as_posix() for p in PAGES])
def test_a_page_s_python_runs(page, tmp_path, monkeypatch):
    pytest.importorskip("pyvista")
    monkeypatch.chdir(tmp_path)
    _demo_files(tmp_path / "manifill-demo")
    import manifill  # the pages' own example names for "your files": the same mesh and samples

    manifill.write_mesh(tmp_path / "scalp.vtp", *manifill.read_mesh(tmp_path / "manifill-demo" / "sphere.ply"))
    (tmp_path / "electrodes.csv").write_bytes((tmp_path / "manifill-demo" / "samples.csv").read_bytes())
    V, _ = manifill.read_mesh(tmp_path / "scalp.vtp")  # arrows: a rotation about z at 30 vertices, tangent
    idx = np.arange(0, len(V), len(V) // 30)[:30]
    arrows = np.cross(V[idx] / np.linalg.norm(V[idx], axis=1, keepdims=True), [0.0, 0.0, 1.0])
    np.savetxt(tmp_path / "arrows.csv", np.column_stack([idx, arrows]), delimiter=",", header="vertex,vx,vy,vz",
               comments="", fmt=["%d", "%.9g", "%.9g", "%.9g"])
    scope = {}
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # the pages use today's names
        for code in blocks(page.read_text(encoding="utf-8")):
            exec(compile(code, str(page), "exec"), scope)
