"""``python -m bench.eeg_series --smoke`` runs end to end and writes its JSON (issue 14's EEG series benchmark).

In a subprocess from the repository root; no timing is asserted. The smoke run writes its
inputs as a user would (a ``.vtp`` mesh, an NPZ with ``idx``, ``vals`` and ``times``), runs
``python -m manifill reconstruct ... -o OUT.xdmf`` in several chunks of time steps, and reads
the XDMF back with meshio (every step there, a few equal to ``manifill.reconstruct`` on their
columns) and with pyvista.
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytest.importorskip("h5py")
pytest.importorskip("meshio")


def test_eeg_series_smoke(tmp_path):
    out = tmp_path / "eeg_series.json"
    p = subprocess.run([sys.executable, "-m", "bench.eeg_series", "--smoke", "--out", str(out)], cwd=ROOT,
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-4000:]
    assert "| T | method | input | vertices |" in p.stdout
    data = json.loads(out.read_text(encoding="utf-8"))
    rows = data["rows"]
    assert [r["steps"] for r in rows] == [30, 90]
    for r in rows:
        assert r["channels"] == 70 and r["input"] == "npz" and r["method"] == "default"
        assert r["seconds"] > 0 and r["peak_mb"] > 0
        # several chunks of at most 16 steps cover every step once
        assert r["chunk"] == 16 and r["chunks"] == -(-r["steps"] // 16)
        m = r["meshio"]
        assert m["steps"] == r["steps"], m
        assert len(m["checked"]) == 5 and m["checked"][-1] == r["steps"] - 1
        assert m["max_diff"] <= 1e-12 and m["time_diff"] == 0.0 and m["points_diff"] == 0.0
        assert m["scale"] > 0.1  # the field is not trivially zero
        if importlib_has("pyvista"):
            assert r["pyvista"]["steps"] == r["steps"] and r["pyvista"]["max_diff"] <= 1e-12, r["pyvista"]
    assert data["markdown"].count("\n") == len(rows) + 1


def importlib_has(name):
    import importlib.util

    return importlib.util.find_spec(name) is not None
