"""The README is the front door: its Python blocks run, its set-up commands are what CI runs."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_the_readme_is_a_landing_page():
    assert len(README.splitlines()) <= 200
    first = re.search(r"```python\n(.*?)```", README, flags=re.S).group(1)
    assert "read_mesh(" in first and "read_samples(" in first  # the first code reads the user's own files


def _demo_files(folder):
    """What ``manifill demo`` writes that the README reads: the mesh and a CSV of positions and values."""
    import numpy as np

    import manifill
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(3)
    folder.mkdir()
    manifill.write_mesh(folder / "sphere.ply", V, F)
    idx = np.arange(0, len(V), 7)
    table = np.column_stack([V[idx], np.sin(2 * V[idx, 0]) + V[idx, 1] * V[idx, 2]])
    np.savetxt(folder / "samples.csv", table, fmt="%.17g", delimiter=",", header="x,y,z,value", comments="")


def test_readme_python_blocks_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _demo_files(tmp_path / "manifill-demo")
    blocks = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert blocks, "README has no python block"
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {})


def test_ci_runs_the_readme_test_command():
    lines = README.splitlines()
    i = next(k for k, line in enumerate(lines) if line.startswith("<!-- test-command"))
    command = lines[i + 2]
    assert "pytest" in command and "venv" in command
    assert "README.md" in (ROOT / ".ci" / "run").read_text()
