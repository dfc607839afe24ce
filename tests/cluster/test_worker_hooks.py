"""What a batch worker hands to manifill: its memory limit (``MANIFILL_MEMORY_LIMIT``) and, in tests only, a
kill between writing a temporary output and renaming it (``MANIFILL_TEST_KILL_ONCE``)."""

import signal
import subprocess
import sys

import numpy as np
import pytest

from manifill.errors import ResourceError
from manifill.io.files import KILL_ONCE_ENV
from manifill.memory import LIMIT_ENV, available_bytes, check_fits

WRITE = """
import sys
from manifill.io.files import atomic_path
with atomic_path(sys.argv[1]) as tmp:
    open(tmp, "w").write("whole")
"""


def test_a_worker_limit_caps_the_memory_manifill_counts(monkeypatch):
    monkeypatch.delenv(LIMIT_ENV, raising=False)
    free = available_bytes()
    monkeypatch.setenv(LIMIT_ENV, str(10**15))
    assert available_bytes() == free or abs(available_bytes() - free) < 0.05 * free  # no tighter than the system
    with open("/proc/self/status") as fh:
        rss = next(int(ln.split()[1]) * 1024 for ln in fh if ln.startswith("VmRSS:"))
    monkeypatch.setenv(LIMIT_ENV, str(rss + 50 * 2**20))
    assert 0 <= available_bytes() <= 50 * 2**20 + 2**22  # what is left of the limit, not the machine's memory
    with pytest.raises(ResourceError, match="needs about"):
        check_fits(200 * 2**20, "a test array", "ask for less")
    monkeypatch.setenv(LIMIT_ENV, "1")
    assert available_bytes() == 0


@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL")
def test_the_kill_hook_dies_once_between_the_temporary_file_and_the_rename(tmp_path):
    out, marker = tmp_path / "o.txt", tmp_path / "marker"
    env = {KILL_ONCE_ENV: str(marker), "PATH": "/usr/bin:/bin"}
    first = subprocess.run([sys.executable, "-c", WRITE, str(out)], env=env, capture_output=True)
    assert first.returncode == -signal.SIGKILL and marker.exists() and not out.exists()
    assert [p.name.startswith(".o.txt.") for p in tmp_path.iterdir() if p.name != "marker"] == [True]  # the stale temp
    second = subprocess.run([sys.executable, "-c", WRITE, str(out)], env=env, capture_output=True)
    assert second.returncode == 0 and out.read_text() == "whole"


def test_a_mesh_read_twice_in_a_job_is_parsed_once_and_each_read_is_its_own_copy(tmp_path, monkeypatch):
    from manifill.io import registry
    from manifill.mesh.shapes import icosphere

    path = tmp_path / "s.ply"
    V, F = icosphere(2)
    registry.write_mesh(path, V, F)
    parsed = []
    real = registry._read_or_points
    monkeypatch.setattr(registry, "_read_or_points", lambda p, fmt, points: parsed.append(p) or real(p, fmt, points))
    with registry.reading_once():
        a = registry.read_mesh_file(path)
        a.V[:] = 0.0  # a caller's change does not reach the next read
        b = registry.read_mesh_file(path)
        assert len(parsed) == 1 and np.array_equal(b.V, V) and np.array_equal(b.F, F)
        registry.write_mesh(path, 2 * V, F)  # a changed file is parsed again
        c = registry.read_mesh_file(path)
        assert len(parsed) == 2 and np.allclose(c.V, 2 * V)
    registry.read_mesh_file(path)
    registry.read_mesh_file(path)
    assert len(parsed) == 4  # outside the block every read parses
