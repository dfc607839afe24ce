"""An EEG-like time series end to end (issue 14): read, reconstruct and write XDMF, in time and memory.

``python -m bench.eeg_series [--smoke] [--steps 1000,3000,10000] [--level 6] [--methods default,harmonic]
[--chunk T] [--csv] [--out FILE]``

Target (issue 14): 10,000 time points of 70 channels on a 32k scalp mesh, end to end (read the
files, reconstruct, write ``.xdmf``), in <= 60 s, with flat memory (the peak does not grow with
the number of time steps beyond one output chunk: :func:`manifill.io.stream.reconstruct_series`
never holds the ``(n, T)`` result whole).

The mesh stands in for a scalp: ``icosphere(level)`` (6: 40,962 vertices, the manifill shape
nearest above 32k; 5 has 10,242) stretched to a head-sized ellipsoid (semi-axes 0.075, 0.095,
0.085 m), written as ``.vtp``. The 70 "electrodes" are the vertices nearest a Fibonacci spiral
over the upper half (z > 0.1 of the height), turned by a seeded random angle. The values
(``(70, T)``, 500 Hz) are a few low spatial harmonics (``x``, ``y``, ``z``, ``xy``, ``x^2 - y^2``,
``yz``) whose amplitudes are sinusoids of EEG frequencies (alpha 10 Hz, theta 6 Hz, beta 20 Hz,
...) plus 2 % white noise (seed 0); written as an NPZ with ``idx``, ``vals`` and ``times`` (and,
with ``--csv``, also as a wide CSV ``vertex,t0,t1,...`` timed as a separate input).

Each (T, method, input) runs ``python -m manifill reconstruct MESH SAMPLES -o OUT.xdmf`` in a fresh
child process under ``/usr/bin/time -v`` (wall seconds and "Maximum resident set size"; without
it, a wrapper child reports ``ru_maxrss`` of its own child), with the default chunking
(``--chunk``: the CLI's ``--chunk``; ``--smoke``: 16, so several chunks). Then a
second child checks the output: meshio's ``TimeSeriesReader`` counts the steps (= T) and reads
five of them, compared with ``manifill.reconstruct`` on those columns (max abs difference; the
field's scale is ~1); a third child opens it with ``pyvista.XdmfReader`` (number of times, the last
step's values against the same reference), and reports the error if it cannot; only up to
``--pyvista-max-steps`` (3,000) steps: the reader took 24 s on 3,000 steps and more than 300 s on
10,000. Writes JSON
(``bench/results/eeg_series.json``, or ``--out``) and prints a markdown table. ``--smoke``: a tiny
mesh and few steps, in seconds (for the tests).
"""

import argparse
import importlib.metadata as md
import json
import os
import platform
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import meshio
import numpy as np

import manifill
from manifill.io import read_mesh_file, write_mesh
from manifill.mesh.shapes import icosphere

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "bench" / "results" / "eeg_series.json"
CHANNELS = 70
RATE = 500.0  # Hz
AXES = (0.075, 0.095, 0.085)  # semi-axes of the head (m)
CHECKED = 5  # steps compared with manifill.reconstruct
TIME_V = "/usr/bin/time"
PYVISTA_MAX = 3000  # pyvista's XdmfReader took 24 s on 3,000 steps and > 300 s on 10,000 (it grows faster than T)
# spatial harmonics (functions of the unit-sphere position) and their time courses (Hz, amplitude, phase)
HARMONICS = (
    (lambda u: u[:, 0], 10.0, 1.0, 0.0),
    (lambda u: u[:, 1], 6.0, 0.6, 1.1),
    (lambda u: u[:, 2], 1.5, 0.8, 0.4),
    (lambda u: u[:, 0] * u[:, 1], 20.0, 0.4, 2.0),
    (lambda u: u[:, 0] ** 2 - u[:, 1] ** 2, 10.5, 0.5, 0.7),
    (lambda u: u[:, 1] * u[:, 2], 3.0, 0.5, 2.9),
)


#: ``--cut H``: keep the head above ``z = H c`` (c its vertical semi-axis), open at the neck like a scalp.
CUT = None


def scalp(level, cut=None):
    """The stand-in scalp: ``icosphere(level)`` stretched to the ellipsoid :data:`AXES`; (V, F).

    With ``cut`` (default :data:`CUT`): only the faces whose corners all lie above ``z = cut c``, the
    vertices renumbered (``level 6``, ``cut -0.56``: 31,909 vertices, a scalp open at the neck).
    """
    V, F = icosphere(level)
    cut = CUT if cut is None else cut
    if cut is not None:
        F = F[(V[F, 2] > cut).all(axis=1)]
        used = np.unique(F)
        new = np.full(len(V), -1, dtype=np.int64)
        new[used] = np.arange(len(used))
        V, F = V[used], new[F]
    return V * np.asarray(AXES), F


def electrodes(V, count=CHANNELS, seed=0):
    """``count`` distinct vertices nearest a Fibonacci spiral over the upper half, turned by a seeded angle."""
    U = V / np.asarray(AXES)
    turn = np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi)
    picked = []
    m = count
    while len(picked) < count:
        j = np.arange(m) + 0.5
        z = 1.0 - 0.9 * j / m  # 1 .. 0.1: the upper half, above a fringe
        phi = j * np.pi * (3.0 - np.sqrt(5.0)) + turn
        r = np.sqrt(1.0 - z ** 2)
        P = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
        near = np.argmin(((U[None, :, :] - P[:, None, :]) ** 2).sum(-1), axis=1) if len(U) * m < 4e7 else \
            np.array([np.argmin(((U - p) ** 2).sum(1)) for p in P])
        picked = list(dict.fromkeys(near.tolist()))  # in spiral order, without repeats
        m += 1
    return np.array(picked[:count], dtype=np.int64)


def eeg(V, idx, steps, seed=0):
    """The synthetic EEG at vertices ``idx``: (len(idx), steps) values and (steps,) times in seconds."""
    U = V[idx] / np.asarray(AXES)
    U = U / np.linalg.norm(U, axis=1, keepdims=True)
    t = np.arange(steps) / RATE
    vals = np.zeros((len(idx), steps))
    for f, hz, amp, phase in HARMONICS:
        vals += np.outer(f(U), amp * np.sin(2.0 * np.pi * hz * t + phase) * (1.0 + 0.3 * np.sin(0.7 * t + phase)))
    vals += 0.02 * np.random.default_rng([seed, steps]).standard_normal(vals.shape)
    return vals, t


def write_inputs(folder, level, steps, csv=False):
    """The mesh (``scalp.vtp``) and the samples (``eeg.npz``, and ``eeg.csv`` if asked) in ``folder``."""
    V, F = scalp(level)
    idx = electrodes(V)
    vals, times = eeg(V, idx, steps)
    folder = Path(folder)
    mesh = folder / "scalp.vtp"
    write_mesh(mesh, V, F)
    files = {"npz": folder / "eeg.npz"}
    np.savez(files["npz"], idx=idx, vals=vals, times=times)
    if csv:
        files["csv"] = folder / "eeg.csv"
        head = "vertex," + ",".join(repr(float(x)) for x in times)
        np.savetxt(files["csv"], np.column_stack([idx, vals]), delimiter=",", header=head, comments="",
                   fmt=["%d"] + ["%.17g"] * steps)
    return mesh, files, len(V)


def _parse_time_v(text):
    """Wall seconds and peak RSS (MB) from ``/usr/bin/time -v``'s report."""
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", text)
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", text)
    secs = None
    if wall:
        secs = 0.0
        for part in wall.group(1).split(":"):
            secs = 60.0 * secs + float(part)
    return secs, (int(rss.group(1)) / 1024.0 if rss else None)


def run_cli(mesh, samples, out, method, chunk=None):
    """``python -m manifill reconstruct`` in a child: wall seconds, peak RSS (MB), its stdout."""
    cmd = [sys.executable, "-m", "manifill", "reconstruct", str(mesh), str(samples), "-o", str(out), "-v"]
    if method != "default":
        cmd += ["--method", method]
    if chunk:
        cmd += ["--chunk", str(chunk)]
    timed = os.access(TIME_V, os.X_OK)
    full = [TIME_V, "-v"] + cmd if timed else [sys.executable, "-m", "bench.eeg_series", "--rusage", "--"] + cmd
    t = time.perf_counter()
    p = subprocess.run(full, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed (exit {p.returncode}):\n{p.stdout[-2000:]}\n{p.stderr[-3000:]}")
    if timed:
        secs, mb = _parse_time_v(p.stderr)
    else:
        secs, mb = wall, float(p.stderr.strip().splitlines()[-1].split()[-1])
    return {"seconds": secs if secs is not None else wall, "peak_mb": mb, "rss_by": "time -v" if timed else
            "ru_maxrss", "stdout": p.stdout}


def rusage(cmd):
    """Run ``cmd``; print its peak RSS (``ru_maxrss`` of this process's children, MB) last on stderr."""
    rc = subprocess.run(cmd).returncode
    print(f"peak_mb {resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0}", file=sys.stderr)
    return rc


def _columns(T):
    return sorted({int(j) for j in np.linspace(0, T - 1, CHECKED).round()})


def check_meshio(cfg):
    """Steps and values of the XDMF through meshio, against ``manifill.reconstruct`` on a few columns."""
    m = read_mesh_file(cfg["mesh"])
    d = np.load(cfg["samples"])
    cols = _columns(d["vals"].shape[1])
    opts = {} if cfg["method"] == "default" else {"method": cfg["method"]}
    ref = manifill.reconstruct(m.V, m.F, d["idx"], d["vals"][:, cols], **opts).values.reshape(len(m.V), -1)
    diff, tdiff = 0.0, 0.0
    with meshio.xdmf.TimeSeriesReader(cfg["out"]) as r:
        points, _ = r.read_points_cells()
        steps = r.num_steps
        for i, j in enumerate(cols):
            t, pd, _ = r.read_data(j)
            diff = max(diff, float(np.max(np.abs(np.asarray(pd["value"]).ravel() - ref[:, i]))))
            tdiff = max(tdiff, abs(float(t) - float(d["times"][j])))
    return {"steps": int(steps), "checked": cols, "max_diff": diff, "time_diff": tdiff,
            "points_diff": float(np.max(np.abs(np.asarray(points) - m.V))), "scale": float(np.abs(ref).max())}


def check_pyvista(cfg):
    """The XDMF through ``pyvista.XdmfReader``: its number of times and the last step against the reference."""
    import pyvista as pv

    m = read_mesh_file(cfg["mesh"])
    d = np.load(cfg["samples"])
    j = d["vals"].shape[1] - 1
    opts = {} if cfg["method"] == "default" else {"method": cfg["method"]}
    ref = manifill.reconstruct(m.V, m.F, d["idx"], d["vals"][:, [j]], **opts).values.ravel()
    t = time.perf_counter()
    r = pv.XdmfReader(cfg["out"])
    times = list(r.time_values)
    r.set_active_time_value(times[j])
    mesh = r.read()
    if isinstance(mesh, pv.MultiBlock):
        mesh = mesh[0]
    got = np.asarray(mesh.point_data["value"]).ravel()
    return {"steps": len(times), "max_diff": float(np.max(np.abs(got - ref))), "seconds": time.perf_counter() - t}


def run_check(kind, cfg, timeout):
    """A check in a fresh child (``kind``: meshio or pyvista); its dict, or ``{"error": ...}``."""
    try:
        p = subprocess.run([sys.executable, "-m", "bench.eeg_series", "--check", kind, json.dumps(cfg)], cwd=ROOT,
                           capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {timeout} s"}
    if p.returncode != 0:
        return {"error": (p.stderr.strip().splitlines() or ["exit %d" % p.returncode])[-1][:300]}
    return json.loads(p.stdout.strip().splitlines()[-1])


def _chunking(stdout):
    m = re.search(r"in (\d+) chunk\(s\) of (\d+)", stdout)
    return (int(m.group(1)), int(m.group(2))) if m else (None, None)


def measure(level, T, method, kind, pyvista_timeout, keep=False, chunk=None, pyvista_max=PYVISTA_MAX):
    """One (T, method, input kind) end to end, then its checks; a JSON-able row."""
    folder = Path(tempfile.mkdtemp(prefix="eeg_series_"))
    try:
        mesh, files, n = write_inputs(folder, level, T, csv=kind == "csv")
        out = folder / "eeg.xdmf"
        print(f"T={T:,} {method} {kind}: manifill reconstruct on {n:,} vertices ...", file=sys.stderr, flush=True)
        run = run_cli(mesh, files[kind], out, method, chunk)
        chunks, chunk = _chunking(run["stdout"])
        cfg = {"mesh": str(mesh), "samples": str(files["npz"]), "out": str(out), "method": method}
        row = {"steps": T, "method": method, "input": kind, "vertices": n, "channels": CHANNELS,
               "seconds": run["seconds"], "peak_mb": run["peak_mb"], "rss_by": run["rss_by"],
               "seconds_per_1000": 1000.0 * run["seconds"] / T, "chunks": chunks, "chunk": chunk,
               "cli_stdout": run["stdout"].strip().splitlines()[-12:],
               "input_mb": files[kind].stat().st_size / 2**20,
               "output_mb": sum(p.stat().st_size for p in folder.glob("eeg.*") if p.suffix in (".xdmf", ".h5"))
               / 2**20}
        row["meshio"] = run_check("meshio", cfg, 900)
        row["pyvista"] = (run_check("pyvista", cfg, pyvista_timeout) if pyvista_timeout and T <= pyvista_max else
                          {"error": f"skipped (T > {pyvista_max:,})" if pyvista_timeout else "skipped"})
        row["uptime"] = _load()
        ok = row["meshio"].get("steps") == T
        print(f"T={T:,} {method} {kind}: {row['seconds']:.1f} s, peak {row['peak_mb']:,.0f} MB, meshio "
              f"{row['meshio'].get('steps')} steps ({'ok' if ok else 'WRONG'}), max diff "
              f"{row['meshio'].get('max_diff', float('nan')):.1e}, pyvista "
              f"{row['pyvista'].get('max_diff', row['pyvista'].get('error'))}", file=sys.stderr, flush=True)
        return row
    finally:
        if not keep:
            shutil.rmtree(folder, ignore_errors=True)


def _load():
    try:
        return os.getloadavg()
    except OSError:
        return None


def table(rows):
    """Markdown: one row per run."""
    lines = ["| T | method | input | vertices | chunks x steps | seconds | peak MB | s per 1,000 steps | "
             "meshio steps | max diff (meshio) | pyvista | target <= 60 s |", "|---" * 12 + "|"]
    for r in rows:
        mi, pv = r["meshio"], r["pyvista"]
        pvs = (f"{pv['steps']} steps, diff {pv['max_diff']:.1e}" if "max_diff" in pv else f"error: {pv['error']}")
        verdict = ("pass" if r["seconds"] <= 60.0 else "**fail**") if r["steps"] >= 10_000 else "-"
        lines.append(f"| {r['steps']:,} | {r['method']} | {r['input']} | {r['vertices']:,} | {r['chunks']} x "
                     f"{r['chunk']} | {r['seconds']:.1f} | {r['peak_mb']:,.0f} | {r['seconds_per_1000']:.2f} | "
                     f"{mi.get('steps', mi.get('error'))} | {mi.get('max_diff', float('nan')):.1e} | {pvs} | "
                     f"{verdict} |")
    return "\n".join(lines)


def save(out, rows, argv, started):
    """The JSON of the rows so far: command, machine, load, versions, rows and their markdown."""
    versions = {"python": platform.python_version()}
    for name in ("numpy", "scipy", "h5py", "meshio", "pyvista", "manifill", "pypardiso"):
        try:
            versions[name] = md.version(name)
        except md.PackageNotFoundError:
            versions[name] = "not installed"
    out.parent.mkdir(parents=True, exist_ok=True)
    cmd = "python -m bench.eeg_series " + " ".join(sys.argv[1:] if argv is None else argv)
    out.write_text(json.dumps({"command": cmd, "machine": platform.platform(), "cpus": os.cpu_count(),
                               "versions": versions, "elapsed": time.time() - started, "rows": rows,
                               "markdown": table(rows)}, indent=1) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="a tiny mesh and few steps (seconds; for the tests)")
    ap.add_argument("--steps", default="1000,3000,10000", help="numbers of time steps, comma-separated")
    ap.add_argument("--level", type=int, default=6, help="icosphere subdivisions (6: 40,962 vertices)")
    ap.add_argument("--methods", default="default", help="comma-separated: default, harmonic, ...")
    ap.add_argument("--chunk", type=int, help="time steps per chunk (default: the CLI's, by memory)")
    ap.add_argument("--cut", type=float, help="keep the head above z = CUT x its height: a scalp open at the neck "
                                              "(-0.56 with --level 6: 31,909 vertices)")
    ap.add_argument("--csv", action="store_true", help="also time the largest T read from a wide CSV")
    ap.add_argument("--pyvista-timeout", type=float, default=300.0, help="seconds for the pyvista check (0: skip)")
    ap.add_argument("--pyvista-max-steps", type=int, default=PYVISTA_MAX,
                    help="skip the pyvista check above this many steps (its reader grows faster than T)")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folders (their paths on stderr)")
    ap.add_argument("--out", help=f"JSON file (default {OUT.relative_to(ROOT)}; smoke: a temporary file)")
    ap.add_argument("--check", nargs=2, help=argparse.SUPPRESS)
    given = sys.argv[1:] if argv is None else list(argv)
    if given[:2] == ["--rusage", "--"]:  # the wrapper child without /usr/bin/time
        return rusage(given[2:])
    args = ap.parse_args(argv)
    global CUT
    CUT = args.cut
    if args.check is not None:
        kind, cfg = args.check
        print(json.dumps((check_meshio if kind == "meshio" else check_pyvista)(json.loads(cfg))))
        return 0
    if args.smoke:
        args.level, args.steps, args.methods, args.chunk = 3, "30,90", "default", args.chunk or 16
    out = Path(args.out) if args.out else (Path(tempfile.gettempdir()) / "eeg_series_smoke.json" if args.smoke
                                           else OUT)
    started = time.time()
    steps = [int(x) for x in args.steps.split(",")]
    rows = []
    runs = [(T, m, "npz") for m in args.methods.split(",") for T in steps]
    if args.csv:
        runs.append((max(steps), args.methods.split(",")[0], "csv"))
    for T, method, kind in runs:
        rows.append(measure(args.level, T, method, kind, args.pyvista_timeout, args.keep, args.chunk,
                            args.pyvista_max_steps))
        save(out, rows, argv, started)  # after every run: a partial run keeps what it measured
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
