"""ruff passes on the package, its tests, the benchmarks, the docs' configuration and the gallery (the rules of
pyproject.toml's [tool.ruff]; the pre-commit configuration runs the same check on each commit)."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _ruff():
    beside = Path(sys.executable).with_name("ruff")
    found = str(beside) if beside.exists() else shutil.which("ruff")
    if found is None:
        pytest.skip("ruff is not installed (pip install -e '.[test]')")
    return found


def test_ruff_is_clean():
    done = subprocess.run([_ruff(), "check", "--no-cache", "src", "tests", "bench", "docs", "examples"],
                          capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-1000:]


def test_ruff_sees_a_fault(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import os\n")
    done = subprocess.run([_ruff(), "check", "--no-cache", "--config", str(ROOT / "pyproject.toml"), str(bad)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 1 and "F401" in done.stdout, done.stdout
