"""The benchmark entry point runs end to end on tiny meshes and writes its markdown and plots.

``python -m bench all --smoke --out <tmp>`` from the repository root, in a
subprocess; no timing is asserted. The benchmark-only peers (potpourri3d, mne)
may be missing: their rows then say "not installed" and the head case is
skipped with a note, and the run still succeeds. ``python -m bench.many_fields --smoke``
likewise (issue 14's many-fields benchmark), with its equality checks.
"""

import importlib.util
import json
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
    # one table per (mesh, field) with random samples: a header row with the k columns, and a row per method
    assert text.count("| method | k = 10 | k = 30 |") == 8
    has_mne = importlib.util.find_spec("mne") is not None
    # the head case: one column per EEG montage, or a note saying why it is missing
    assert ("| method | k = 32 (biosemi32) | k = 64 (biosemi64) |" in text) == has_mne
    assert ("case head-eeg skipped: mne is not installed" in text) == (not has_mne)
    for row in ("manifill default (biharmonic, projected onto the samples' range) |",
                "libigl biharmonic (k=2, points) |",
                "potpourri3d vector heat extend_scalar |", "pyvista Gaussian kernel interpolate |",
                "MNE spherical spline (interpolate_bads, reg 1e-5) |", "manifill biharmonic, smoothing=auto |"):
        assert row in text, row
    if importlib.util.find_spec("potpourri3d") is None:
        assert "not installed (potpourri3d: pip install potpourri3d)" in text
    # the targets: a line per (target, case), each with a verdict
    assert "### Targets (issue 12)" in text and "- **Targets of issue 12**:" in text
    targets = [line for line in text.splitlines() if line.startswith("| default / best peer |")]
    assert len(targets) == 8 + 2 * has_mne  # the random-sample cases, then the head and the open scalp
    assert all(re.search(r"\| (pass|\*\*fail\*\*|no result) \|", line) for line in targets)
    assert "| level | vertices |" in text and "| series | slope |" in text
    pngs = sorted((out / "benchmarks").glob("*.png"))
    names = {p.name for p in pngs}
    assert "scaling.png" in names
    assert len([n for n in names if n.startswith("accuracy_")]) == 8 + 2 * has_mne
    for png in pngs:
        assert png.stat().st_size > 1000, png
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", png
        assert f"benchmarks/{png.name}" in text, png.name


def test_many_fields_smoke(tmp_path):
    # python -m bench.many_fields --smoke: every configuration's child runs, apply equals reconstruct, manifill
    # equals igl.harmonic off the fixed set, and the tables and the JSON are written
    out = tmp_path / "many_fields.json"
    p = subprocess.run([sys.executable, "-m", "bench.many_fields", "--smoke", "--out", str(out)], cwd=ROOT,
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-4000:]
    assert "| k | method | reconstruct / igl |" in p.stdout
    rows = json.loads(out.read_text(encoding="utf-8"))["rows"]
    assert [r["method"] for r in rows] == ["gvf-harmonic", "harmonic", "default"]
    for r in rows:
        assert max(r["apply_vs_reconstruct"].values()) <= 1e-12
        assert r["igl_vs_manifill"] <= 1e-10
        assert r["fixed"] == (r["k"] if r["method"] == "harmonic" else r["igl_fixed"])
        assert {"reconstruct", "build", "all", "chunks", "one", "igl"} <= set(r["seconds"])


def test_batch_speed_smoke(tmp_path):
    # python -m bench.batch_speed --smoke: the serial loop and the batch on a LocalCluster give the same files, a
    # series over workers equals one process's, the scheduler's overhead is measured, and the JSON is written
    pytest.importorskip("distributed")
    out = tmp_path / "batch_speed.json"
    p = subprocess.run([sys.executable, "-m", "bench.batch_speed", "--smoke", "--out", str(out)], cwd=ROOT,
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-4000:]
    d = json.loads(out.read_text(encoding="utf-8"))
    m, f, o = d["meshes"], d["fields"], d["overhead"]
    assert m["counts"] == {"done": 4} and m["max_abs_diff"] <= 1e-12 and len(m["peak_mb_per_worker"]) == 2
    assert m["serial_seconds"] > 0 and m["batch_seconds"] > 0 and min(m["job_peak_mb"].values()) > 10
    assert f["max_abs_diff"] <= 1e-12 and f["one"]["fields"] == f["workers"]["fields"] == 40
    assert o["counts"] == {"done": 50} and o["per_task_ms"] > 0 and d["estimate"]["subjects"] == 10_000
    assert "| jobs | vertices |" in p.stdout and "On paper" in p.stdout
