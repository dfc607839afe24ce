"""The command line never half-does: outputs checked before the work, inputs never overwritten, signals clean up."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import assert_usage_error, files, run

from manifill.io import write_mesh
from manifill.mesh.shapes import icosphere
import importlib


@pytest.fixture
def case(tmp_path):
    V, F = icosphere(2)
    write_mesh(tmp_path / "m.ply", V, F)
    idx = np.arange(0, len(V), 11)
    rows = "".join(f"{i},{float(V[i, 0])!r},{float(V[i, 1])!r}\n" for i in idx)
    (tmp_path / "s.csv").write_text("vertex,t,u\n" + rows)
    return tmp_path


def test_output_equal_to_an_input_is_refused_and_the_input_kept(case, capsys):
    before = (case / "m.ply").read_bytes()
    code, out, err = run(capsys, "harmonic", case / "m.ply", case / "s.csv", "-o", case / "m.ply")
    assert "is also an input" in assert_usage_error(code, out, err)
    assert (case / "m.ply").read_bytes() == before
    # the same file under another spelling
    code, out, err = run(capsys, "reconstruct", case / "m.ply", case / "s.csv", "-o",
                         str(case / "sub" / ".." / "m.ply").replace("sub/..", "."))
    assert "is also an input" in assert_usage_error(code, out, err)
    code, out, err = run(capsys, "harmonic", case / "m.ply", case / "s.csv", "-o", case / "o.vtu",
                         "--html", case / "s.csv")
    assert assert_usage_error(code, out, err)
    assert files(case) == ["m.ply", "s.csv"]


def test_two_options_writing_one_file_are_refused(case, capsys):
    code, out, err = run(capsys, "reconstruct", case / "m.ply", case / "s.csv", "-o", case / "o.vtu",
                         "--render", case / "p.png", "--html", case / "p.png")
    assert "change the name" in assert_usage_error(code, out, err)  # .png is no .html
    code, out, err = run(capsys, "volume", case / "m.ply", case / "s.csv", "-o", case / "o.vti",
                         "--render", case / "o.vti")
    assert assert_usage_error(code, out, err)
    assert files(case) == ["m.ply", "s.csv"]


def test_every_output_is_checked_before_the_work(case, capsys):
    # /sys refuses new files even to root: the folder exists but is not writable
    assert os.path.isdir("/sys")
    code, out, err = run(capsys, "reconstruct", case / "m.ply", case / "s.csv", "-o", case / "o.vtu",
                         "--html", "/sys/viewer.html")
    assert "not writable" in assert_usage_error(code, out, err)
    assert files(case) == ["m.ply", "s.csv"]  # -o was not written first
    code, out, err = run(capsys, "reconstruct", case / "m.ply", case / "s.csv", "-o", case / "o.vtu",
                         "--render", case / "nope" / "p.png")
    assert "does not exist" in assert_usage_error(code, out, err)
    code, out, err = run(capsys, "reconstruct", case / "m.ply", case / "s.csv", "-o", case / "o.vtu",
                         "--field", "nope")
    assert "'nope' is not one of the fields (t, u)" in assert_usage_error(code, out, err)
    assert files(case) == ["m.ply", "s.csv"]


def test_field_chooses_the_render_and_the_viewer_shows_all(case, capsys):
    from manifill.viz.viewer import embedded_arrays

    code, out, _ = run(capsys, "harmonic", case / "m.ply", case / "s.csv", "-o", case / "o.vtu", "--html",
                       case / "v.html", "--field", "u", "-q")
    assert code == 0
    page = embedded_arrays(case / "v.html")
    assert list(page["fields"]) == ["t", "u"] and page["field"] == "u"


def test_ply_output_says_which_readers_miss_its_fields(case, capsys):
    code, out, _ = run(capsys, "harmonic", case / "m.ply", case / "s.csv", "-o", case / "o.ply")
    assert code == 0
    note = [line for line in out.splitlines() if line.startswith("note: o.ply")]
    assert len(note) == 1 and "pyvista/VTK/ParaView" in note[0] and ".vtu" in note[0]
    code, out, _ = run(capsys, "harmonic", case / "m.ply", case / "s.csv", "-o", case / "o.vtu")
    assert code == 0 and "note:" not in out


def _big_case(folder):
    V, F = icosphere(7)  # 163,842 vertices: writing its values as CSV takes a while
    write_mesh(folder / "big.ply", V, F)
    idx = np.arange(0, len(V), 97)
    (folder / "s.csv").write_text("vertex,t\n" + "".join(f"{i},{float(V[i, 2])!r}\n" for i in idx))
    (folder / "out.csv").write_text("old result\n")


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_during_the_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path, sig, code):
    _big_case(tmp_path)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    # a shell's background job starts with SIGINT ignored, and Python then keeps it ignored: give the child the
    # default disposition, as a terminal would
    proc = subprocess.Popen([sys.executable, "-m", "manifill", "harmonic", "big.ply", "s.csv", "-o", "out.csv",
                             "--solver", "amg"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=env, text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 120
    seen = False
    while time.monotonic() < deadline and proc.poll() is None:
        if any(name.startswith(".out.csv.") for name in os.listdir(tmp_path)):
            seen = True
            proc.send_signal(sig)
            break
        time.sleep(0.001)
    out, err = proc.communicate(timeout=120)
    if not seen:
        pytest.fail(f"the write was never caught in progress (exit {proc.returncode}): {err}")
    assert proc.returncode == code, err
    assert err.count("\n") == 1 and "Traceback" not in err and "no output was left half-written" in err
    assert (tmp_path / "out.csv").read_text() == "old result\n"
    assert sorted(os.listdir(tmp_path)) == ["big.ply", "out.csv", "s.csv"]


def test_a_name_csv_cannot_hold_is_refused_before_the_work(case, capsys):
    (case / "q.csv").write_text((case / "s.csv").read_text().replace("vertex,t,u", 'vertex,"a,b",u'))
    code, out, err = run(capsys, "harmonic", case / "m.ply", case / "q.csv", "-o", case / "o.csv")
    assert "comma or quote" in assert_usage_error(code, out, err)
    assert files(case) == ["m.ply", "q.csv", "s.csv"]
    code, _, _ = run(capsys, "harmonic", case / "m.ply", case / "q.csv", "-o", case / "o.vtu", "-q")
    assert code == 0  # the same name is fine where the format can hold it


def _wait_for(path, limit=60.0):
    """Until the child has made ``path`` (it does so as the slow call begins)."""
    end = time.monotonic() + limit
    while not path.exists():
        assert time.monotonic() < end, f"the child never reached the call ({path.name})"
        time.sleep(0.02)


SLOW_CALL = """
import sys
import numpy as np
import manifill.cli.reconstruct as rc
from manifill.cli import main

fill = rc.reconstruct


def slow(*args, **kwargs):  # one long compiled call, as a large factorisation or a gp's dense solve makes
    open("started", "w").close()  # the test signals once the call has begun (not after a guessed delay)
    np.linalg.svd(np.random.default_rng(0).normal(size=(4000, 4000)))  # 15 s here
    return fill(*args, **kwargs)


rc.reconstruct = slow
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_is_honoured_within_seconds_even_inside_a_long_compiled_call(tmp_path, sig, code):
    # SIGTERM during --method gp took 43 s: Python runs its handlers only between calls
    V, F = icosphere(2)
    write_mesh(tmp_path / "m.vtu", V, F)
    (tmp_path / "s.csv").write_text("vertex,t\n" + "".join(f"{i},{float(V[i, 2])!r}\n" for i in range(0, 162, 9)))
    proc = subprocess.Popen([sys.executable, "-c", SLOW_CALL, "reconstruct", "m.vtu", "s.csv", "-o", "o.vtu"],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    _wait_for(tmp_path / "started")  # inside the call (on a loaded machine the import alone took over 1.5 s)
    (tmp_path / "started").unlink()
    t = time.monotonic()
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    waited = time.monotonic() - t
    assert proc.returncode == code, err
    assert err.count("\n") == 1 and "Traceback" not in err and "no output was left half-written" in err
    assert importlib.import_module("manifill.cli.main").GRACE_SECONDS <= 3
    assert waited < 6.0, f"stopped after {waited:.1f} s"  # the call alone runs about 15 s more
    assert sorted(os.listdir(tmp_path)) == ["m.vtu", "s.csv"]


SLOW_CLEANUP = """
import sys
import time
import manifill.cli.reconstruct as rc
from manifill.cli import main


def slow(*args, **kwargs):
    open("started", "w").close()  # the test signals once the call has begun (not after a guessed delay)
    try:
        time.sleep(30)  # interruptible: the main thread's own handler runs at once
    finally:
        time.sleep(4.5)  # a clean-up longer than the watchdog's grace: it must be left to finish


rc.reconstruct = slow
sys.exit(main(sys.argv[1:]))
"""


def test_the_watchdog_leaves_a_long_clean_up_to_finish(tmp_path):
    V, F = icosphere(2)
    write_mesh(tmp_path / "m.vtu", V, F)
    (tmp_path / "s.csv").write_text("vertex,t\n" + "".join(f"{i},{float(V[i, 2])!r}\n" for i in range(0, 162, 9)))
    proc = subprocess.Popen([sys.executable, "-c", SLOW_CLEANUP, "reconstruct", "m.vtu", "s.csv", "-o", "o.vtu"],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for(tmp_path / "started")
    (tmp_path / "started").unlink()
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and err == "manifill: terminated; no output was left half-written\n", err
