"""The package type-checks (mypy, the [tool.mypy] of pyproject.toml), and its public API's annotations say what a
user's code gets back: a checker catches a result used as the wrong type."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _mypy(*args):
    pytest.importorskip("mypy")
    return subprocess.run([sys.executable, "-m", "mypy", "--no-incremental", *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=600)


def test_the_package_type_checks():
    done = _mypy("src/manifill")
    assert done.returncode == 0, done.stdout[-3000:]


def test_a_users_wrong_use_of_a_result_is_caught(tmp_path):
    user = tmp_path / "user.py"
    user.write_text("import manifill\n"
                    "V, F = manifill.read_mesh('m.ply')\n"
                    "r = manifill.reconstruct(V, F, [0, 1], [0.0, 1.0])\n"
                    "ok: manifill.Reconstruction = r\n"
                    "wrong: int = manifill.reconstruct(V, F, [0, 1], [0.0, 1.0])\n")
    done = _mypy("--follow-imports=silent", str(user))
    assert done.returncode == 1 and 'user.py:5: error: Incompatible types in assignment (expression has type ' \
                                    '"Reconstruction", variable has type "int")' in done.stdout, done.stdout
