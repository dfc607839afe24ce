"""The benchmark entry point runs end to end on tiny meshes and writes its markdown and plots.

``python -m bench all --smoke --out <tmp>`` from the repository root, in a
subprocess; no timing is asserted.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytest.importorskip("igl")
pytest.importorskip("matplotlib")
pytest.importorskip("pyvista")


def test_bench_all_smoke(tmp_path):
    out = tmp_path / "docs"
    p = subprocess.run([sys.executable, "-m", "bench", "all", "--smoke", "--out", str(out)], cwd=ROOT,
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-4000:]
    md = out / "benchmarks.md"
    assert md.is_file()
    text = md.read_text(encoding="utf-8")
    headings = ("## Accuracy", "### Summary", "## Speed", "## Scaling", "## Where manifill leads and where it trails")
    for heading in headings:
        assert heading in text, heading
    for name in ("python", "numpy", "scipy", "pyamg", "libigl", "manifill"):
        assert re.search(rf"{name} \d", text), name
    # one table per (mesh, field): a header row with the k columns, and a row per method
    assert text.count("| method | k = 10 | k = 30 |") == 5
    assert "manifill gvf-harmonic, delaunay, hermite (default) |" in text
    assert "libigl biharmonic (k=2, points) |" in text
    assert "| level | vertices |" in text and "| series | slope |" in text
    pngs = sorted((out / "benchmarks").glob("*.png"))
    names = {p.name for p in pngs}
    assert "scaling.png" in names
    assert len([n for n in names if n.startswith("accuracy_")]) == 5
    for png in pngs:
        assert png.stat().st_size > 1000, png
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", png
        assert f"benchmarks/{png.name}" in text, png.name
