"""Fuzzing every reader and the command line: a damaged file ends as one manifill error or as a valid result.

Small valid files of every format manifill reads are built in code (an icosphere, a cube of five tetrahedra, a
6 x 6 x 6 voxel mask, a few samples on the sphere), written by manifill and by the common writers (meshio,
pyvista/VTK, nibabel), then damaged by seeded hypothesis strategies: truncation, byte flips, insertions and
deletions, header numbers replaced by huge, negative, fractional or non-numeric values, lines duplicated or
deleted, zlib streams and base64 inside XML damaged, ZIP containers broken. Every read must end in one of two
ways: a valid result (arrays of consistent shapes, every face index in range), or a ReadError, SampleError or
MeshError whose message is one line naming the file ("memory" only in "damaged" wording). Anything else fails:
another exception, a read slower than 5 s or allocating more than 64 MiB at once (tracemalloc), a warning, a
log record or a printed line escaping, a file left beside the input.
A sample of the damaged files also goes through the CLI (``info``, ``harmonic``, ``check``, ``volume``): exit
0 or 2 (1 only for ``check``'s failing condition), exactly one ``manifill: error:`` line for 2, no traceback, no
file but a complete output.

CI budget: this whole file runs in about 40 s on the 2-core CI machine (``--durations``); keep it under 60 s.
``MANIFILL_FUZZ_COUNT=N`` runs N examples per strategy instead and prints the table of inputs and outcomes by
format and class at the end (``pytest tests/io/test_fuzz.py -p no:cacheprovider``).
"""

import io
import os
import re
import shutil
import time
import warnings
from collections import Counter, defaultdict
from itertools import count
from pathlib import Path

import meshio
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from manifill.errors import MeshError, ReadError, SampleError
from manifill.surface.samples import Samples
from manifill.mesh.shapes import icosphere
from fuzzing import SLOW, Seed, base64_runs, LogRecords, peak_memory, damage, run_command, strategies_for
from manifill.io import (read_barriers, read_mask, read_mesh_file, read_samples, read_tets, read_vti, write_mesh,
                         write_tets, write_vti)

COUNT = int(os.environ.get("MANIFILL_FUZZ_COUNT", "0") or 0)
#: examples per (format, strategy) and per command: 60 in CI, N in the counting mode
EXAMPLES = COUNT or 60
CLI_EXAMPLES = COUNT or 60
MOST_MEMORY = 64 * 2**20  # bytes: a file of a few kB that makes a reader allocate more lies about its size
FUZZ = settings(derandomize=True, database=None, max_examples=EXAMPLES, deadline=None, print_blob=False,
                suppress_health_check=list(HealthCheck))
CLI_FUZZ = settings(FUZZ, max_examples=CLI_EXAMPLES)

#: (format, class) -> inputs, for the table of the counting mode
TALLY = Counter()
FAILURES = defaultdict(list)
CLASSES = ("ok", "ReadError", "SampleError", "MeshError", "FAIL")

V_SPHERE, F_SPHERE = icosphere(1)
SAMPLE_VERTICES = [0, 5, 17, 30, 41]


# ---------------------------------------------------------------------------
# seed files
# ---------------------------------------------------------------------------


def _cube_tets():
    """The unit cube as five positively oriented tetrahedra (corner i at (i & 1, i >> 1 & 1, i >> 2))."""
    V = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], dtype=np.float64)
    T = np.array([[1, 0, 3, 5], [2, 0, 3, 6], [4, 0, 5, 6], [7, 3, 5, 6], [0, 3, 5, 6]])
    a, b, c, d = (V[T[:, k]] for k in range(4))
    neg = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) < 0
    T[neg] = T[neg][:, [1, 0, 2, 3]]
    return V, T


def _mask():
    mask = np.zeros((6, 6, 6), dtype=bool)
    mask[1:5, 1:5, 1:5] = True
    return mask


def _csv(rows, header):
    return (header + "\n" + "".join(",".join(repr(float(v)) if j else str(v) for j, v in enumerate(r)) + "\n"
                                    for r in rows)).encode()


def _build_seeds(folder):
    """Every seed file, written into ``folder`` by the writer under test, as {label: Seed}."""
    import nibabel as nib
    import pyvista as pv
    import vtk

    folder = Path(folder)
    V, F = V_SPHERE, F_SPHERE
    t = V[:, 0] + 2 * V[:, 1]
    out = {}

    def add(label, name, reader, write, text=False, zipped=False):
        path = folder / label / name
        path.parent.mkdir()
        _quiet(write, path)
        data = path.read_bytes()
        out[label] = Seed(label, name, data, reader, text, base64_runs(data), zipped)

    mesh = meshio.Mesh(V, [("triangle", F)], point_data={"t": t})
    bad = V.copy()
    bad[0], bad[1, 1], bad[2, 2] = np.nan, np.inf, 1e308
    bad_mesh = meshio.Mesh(bad, [("triangle", F)])
    poly = pv.PolyData(V, np.column_stack([np.full(len(F), 3), F]).ravel())
    poly.point_data["t"] = t

    # surfaces
    add("vtu_ours", "m.vtu", "mesh", lambda p: write_mesh(p, V, F, {"t": t}))
    add("vtu_meshio_ascii", "m.vtu", "mesh", lambda p: meshio.write(p, mesh, binary=False), text=True)
    add("vtu_meshio_binary", "m.vtu", "mesh", lambda p: meshio.write(p, mesh, binary=True, compression=None))
    add("vtu_meshio_zlib", "m.vtu", "mesh", lambda p: meshio.write(p, mesh, binary=True, compression="zlib"))
    add("vtu_nan", "m.vtu", "mesh", lambda p: meshio.write(p, bad_mesh, binary=True, compression="zlib"))
    add("vtp_ours", "m.vtp", "mesh", lambda p: write_mesh(p, V, F, {"t": t}))
    add("vtp_pyvista", "m.vtp", "mesh", lambda p: poly.save(p))
    add("vtp_vtk_appended", "m.vtp", "mesh", lambda p: _vtk_write(vtk.vtkXMLPolyDataWriter(), poly, p))
    add("vtk_ours", "m.vtk", "mesh", lambda p: write_mesh(p, V, F, {"t": t}))
    add("vtk_pyvista_ascii", "m.vtk", "mesh", lambda p: poly.save(p, binary=False), text=True)
    add("vtk_pyvista_binary", "m.vtk", "mesh", lambda p: poly.save(p, binary=True))
    add("ply_ascii", "m.ply", "mesh", lambda p: meshio.write(p, mesh, binary=False), text=True)
    add("ply_binary", "m.ply", "mesh", lambda p: meshio.write(p, mesh, binary=True))
    add("ply_nan", "m.ply", "mesh", lambda p: meshio.write(p, bad_mesh, binary=True))
    add("off", "m.off", "mesh", lambda p: write_mesh(p, V, F), text=True)
    add("obj", "m.obj", "mesh", lambda p: write_mesh(p, V, F), text=True)
    add("stl_ascii", "m.stl", "mesh", lambda p: meshio.write(p, meshio.Mesh(V, [("triangle", F)]), binary=False),
        text=True)
    add("stl_binary", "m.stl", "mesh", lambda p: meshio.write(p, meshio.Mesh(V, [("triangle", F)]), binary=True))
    add("surf_gii", "m.surf.gii", "mesh", lambda p: nib.save(_gifti_surface(nib, V, F), p), text=True)
    add("freesurfer", "lh.pial", "mesh", lambda p: nib.freesurfer.write_geometry(p, V, F))

    # point clouds (the sphere's vertices, no faces)
    cloud = meshio.Mesh(V, [], point_data={"t": t})
    add("points_xyz", "p.xyz", "points", lambda p: p.write_text(
        "# x y z\n" + "".join(f"{a!r} {b!r} {c!r}\n" for a, b, c in V.tolist())), text=True)
    add("points_csv", "p.csv", "points", lambda p: p.write_text(
        "x,y,z,t\n" + "".join(f"{a!r},{b!r},{c!r},{v!r}\n" for (a, b, c), v in zip(V.tolist(), t.tolist()))),
        text=True)
    add("points_ply_ascii", "p.ply", "points", lambda p: meshio.write(p, cloud, binary=False), text=True)
    add("points_ply_binary", "p.ply", "points", lambda p: meshio.write(p, cloud, binary=True))
    add("points_vtp_ours", "p.vtp", "points", lambda p: write_mesh(p, V, None, {"t": t}))
    add("points_vtk_ours", "p.vtk", "points", lambda p: write_mesh(p, V, None, {"t": t}))

    # barriers: paths of vertex indices, positions, per-face labels
    add("barriers_txt", "b.txt", "barriers", lambda p: p.write_text("# walls\n0 1 2 3\n10, 11, 12\n"), text=True)
    add("barriers_csv", "b.csv", "barriers", lambda p: p.write_text(
        "barrier,x,y,z\n" + "".join(f"{j % 2},{a!r},{b!r},{c!r}\n" for j, (a, b, c) in enumerate(V[:6].tolist()))),
        text=True)
    add("barriers_npy", "b.npy", "barriers", lambda p: np.save(p, (V[F].mean(axis=1)[:, 0] > 0).astype(np.int32)))

    # tetrahedra
    TV, TT = _cube_tets()
    tmesh = meshio.Mesh(TV, [("tetra", TT)])
    add("tets_vtu", "t.vtu", "tets", lambda p: write_tets(p, TV, TT))
    add("tets_vtk", "t.vtk", "tets", lambda p: write_tets(p, TV, TT))
    add("tets_msh_ascii", "t.msh", "tets", lambda p: meshio.write(p, tmesh, file_format="gmsh22", binary=False),
        text=True)
    add("tets_msh_binary", "t.msh", "tets", lambda p: meshio.write(p, tmesh, file_format="gmsh22", binary=True))
    add("tets_msh_ours", "t.msh", "tets", lambda p: write_tets(p, TV, TT, {"u": TV[:, 0], "in": TV[:, 1] > 0}))

    # voxels
    mask = _mask()
    grid = pv.ImageData(dimensions=mask.shape)
    grid.point_data["mask"] = mask.ravel(order="F").astype(np.uint8)
    add("vti_ours", "g.vti", "vti", lambda p: write_vti(p, {"mask": mask, "u": np.arange(216.0).reshape(6, 6, 6)}))
    add("vti_vtk_inline", "g.vti", "vti", lambda p: grid.save(p))
    add("vti_vtk_appended", "g.vti", "vti", lambda p: _vtk_write(vtk.vtkXMLImageDataWriter(), grid, p))
    add("mask_vti", "g.vti", "mask", lambda p: write_vti(p, {"mask": mask}))
    add("mask_npy", "g.npy", "mask", lambda p: np.save(p, mask))
    add("mask_npy_str", "g.npy", "mask", lambda p: np.save(p, mask.astype("U1")))

    # samples on the sphere
    idx = np.array(SAMPLE_VERTICES)
    vals = t[idx]
    add("csv_vertex", "s.csv", "samples", lambda p: p.write_bytes(_csv(zip(idx, vals), "vertex,t")), text=True)
    add("csv_xyz", "s.csv", "samples", lambda p: p.write_text(
        "x,y,z,t\n" + "".join(f"{a!r},{b!r},{c!r},{v!r}\n" for (a, b, c), v in zip(V[idx].tolist(), vals.tolist()))),
        text=True)
    add("npz", "s.npz", "samples", lambda p: np.savez(p, idx=idx, vals=vals, names=np.array(["t"])), zipped=True)
    add("npz_compressed", "s.npz", "samples", lambda p: np.savez_compressed(p, points=V[idx], vals=vals),
        zipped=True)
    add("npz_complex", "s.npz", "samples", lambda p: np.savez(p, idx=idx, vals=vals + 1j), zipped=True)
    add("npz_str", "s.npz", "samples", lambda p: np.savez(p, idx=idx.astype(str), vals=vals.astype(str)),
        zipped=True)
    rec = np.zeros(len(idx), dtype=[("vertex", "<i8"), ("t", "<f8")])
    rec["vertex"], rec["t"] = idx, vals
    add("npy_struct", "s.npy", "samples", lambda p: np.save(p, rec))
    crec = np.zeros(len(idx), dtype=[("vertex", "<i8"), ("t", "<c16")])
    add("npy_complex", "s.npy", "samples", lambda p: np.save(p, crec))
    srec = np.zeros(len(idx), dtype=[("vertex", "<U4"), ("t", "S8")])
    add("npy_str", "s.npy", "samples", lambda p: np.save(p, srec))
    per_vertex = np.full(len(V), np.nan, dtype=np.float32)
    per_vertex[idx] = vals
    add("func_gii", "d.func.gii", "samples", lambda p: nib.save(_gifti_data(nib, per_vertex), p), text=True)
    add("morph", "lh.thickness", "samples", lambda p: nib.freesurfer.write_morph_data(p, per_vertex))
    add("mgh", "d.mgh", "samples", lambda p: nib.save(nib.MGHImage(per_vertex.reshape(-1, 1, 1), np.eye(4)), p))
    add("label", "lh.v1.label", "samples", lambda p: p.write_text(
        "#!ascii label  , from subject  vox2ras=TkReg\n" + f"{len(idx)}\n"
        + "".join(f"{i}  {a:.3f}  {b:.3f}  {c:.3f} {v:.6f}\n" for i, (a, b, c), v in zip(idx, V[idx], vals))),
        text=True)
    return out


def _quiet(fn, *args, **kwargs):
    """Run a writer whose notes (meshio's on Gmsh tags, PLY integers) are not what is tested."""
    with warnings.catch_warnings(), io.StringIO() as sink:
        warnings.simplefilter("ignore")
        from contextlib import redirect_stderr

        with redirect_stderr(sink):
            fn(*args, **kwargs)


def _vtk_write(writer, dataset, path):
    """VTK's own XML writer, appended raw data, zlib-compressed."""
    writer.SetFileName(str(path))
    writer.SetInputData(dataset)
    writer.SetDataModeToAppended()
    writer.EncodeAppendedDataOff()
    writer.SetCompressorTypeToZLib()
    writer.Write()


def _gifti_surface(nib, V, F):
    return nib.gifti.GiftiImage(darrays=[
        nib.gifti.GiftiDataArray(V.astype(np.float32), intent="NIFTI_INTENT_POINTSET", datatype="NIFTI_TYPE_FLOAT32"),
        nib.gifti.GiftiDataArray(F.astype(np.int32), intent="NIFTI_INTENT_TRIANGLE", datatype="NIFTI_TYPE_INT32"),
    ])


def _gifti_data(nib, values):
    return nib.gifti.GiftiImage(darrays=[
        nib.gifti.GiftiDataArray(values, intent="NIFTI_INTENT_SHAPE", datatype="NIFTI_TYPE_FLOAT32")])


_SEEDS = {}


def seeds():
    if not _SEEDS:
        import tempfile

        with tempfile.TemporaryDirectory() as folder:
            _SEEDS.update(_build_seeds(folder))
    return _SEEDS


# ---------------------------------------------------------------------------
# damage
# ---------------------------------------------------------------------------

# ---------------------------------------------------------------------------
# outcomes
# ---------------------------------------------------------------------------


def _check_faces(C, n, k, what):
    assert isinstance(C, np.ndarray) and C.ndim == 2 and C.shape[1] == k and C.dtype == np.int64, \
        f"{what}: {type(C).__name__} {getattr(C, 'shape', '')} {getattr(C, 'dtype', '')}"
    assert len(C) > 0, f"{what}: none returned"
    assert C.min() >= 0 and C.max() < n, f"{what}: index {C.min()}..{C.max()} outside 0..{n - 1}"


def _check_points(V):
    assert isinstance(V, np.ndarray) and V.ndim == 2 and V.shape[1] == 3 and V.dtype == np.float64, \
        f"points {getattr(V, 'shape', '')} {getattr(V, 'dtype', '')}"


def check_result(reader, res):
    """Assert that a returned result is consistent (shapes, dtypes, indices in range)."""
    if reader in ("mesh", "points"):
        _check_points(res.V)
        if res.F is not None or reader == "mesh":
            _check_faces(res.F, len(res.V), 3, "faces")
        for k, a in res.point_data.items():
            assert a.shape[:1] == (len(res.V),), f"field {k!r} has shape {a.shape}"
    elif reader == "barriers":
        if isinstance(res, list):
            assert res and all(np.asarray(p).ndim in (1, 2) and len(p) for p in res), res
            assert all(np.isfinite(np.asarray(p, dtype=float)).all() for p in res)
        else:
            assert res.ndim == 1 and res.dtype == np.int64, (res.shape, res.dtype)
    elif reader == "tets":
        V, T = res
        _check_points(V)
        _check_faces(T, len(V), 4, "tetrahedra")
    elif reader in ("vti", "mask"):
        fields, h, o = res
        if reader == "mask":
            fields = {"mask": fields}
            assert fields["mask"].dtype == bool
        shapes = {a.shape[:3] for a in fields.values()}
        assert len(shapes) <= 1 and all(a.ndim in (3, 4) and min(a.shape) > 0 for a in fields.values()), shapes
        for v in (h, o):
            assert v is None or (np.shape(v) == (3,) and np.isfinite(v).all()), v
    else:
        assert isinstance(res, Samples)
        idx, vals = res.idx, res.vals
        assert idx.dtype == np.int64 and idx.ndim == 1 and len(idx) > 0
        assert idx.min() >= 0 and idx.max() < len(V_SPHERE) and len(np.unique(idx)) == len(idx)
        assert vals.shape == (len(idx), len(res.names)) and np.isfinite(vals).all()


READERS = {
    "mesh": read_mesh_file,
    "points": lambda p: read_mesh_file(p, points=True),
    "barriers": read_barriers,
    "tets": read_tets,
    "vti": read_vti,
    "mask": lambda p: read_mask(p)[0:3],
    "samples": lambda p: read_samples(p, V_SPHERE),
}


def outcome(reader, path):
    """Read ``path``: (class, detail); class is 'ok', the manifill error's name, or 'FAIL'."""
    with LogRecords() as logged, peak_memory() as peak:
        cls, detail = _outcome(reader, path)
    if cls != "FAIL" and logged:
        return "FAIL", f"logged {logged[0].name}: {logged[0].getMessage()[:200]}"
    if cls != "FAIL" and peak[0] > MOST_MEMORY:
        return "FAIL", f"allocated {peak[0] / 2**20:.0f} MiB at once for a file of {path.stat().st_size:,} bytes"
    return cls, detail


def _outcome(reader, path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        try:
            res = READERS[reader](path)
        except (ReadError, SampleError, MeshError) as exc:
            cls, msg = type(exc).__name__, str(exc)
            if "\n" in msg or not msg.strip():
                return "FAIL", f"{cls} of {len(msg.splitlines())} lines: {msg!r}"
            if path.name not in msg:
                return "FAIL", f"{cls} without the file name: {msg}"
            if "memory" in msg.lower() and "damaged" not in msg.lower():
                return "FAIL", f"{cls} speaks of memory for a small file: {msg}"
            if VAGUE.search(msg):
                return "FAIL", f"{cls} names no cause, or only Python's: {msg}"
        except Exception as exc:  # noqa: BLE001 - what the fuzzing looks for
            return "FAIL", f"{type(exc).__name__}: {exc}"[:300]
        else:
            cls, msg = "ok", ""
            try:
                check_result(reader, res)
            except AssertionError as exc:
                return "FAIL", f"inconsistent result: {exc}"
        seconds = time.perf_counter() - t0
    if seconds > SLOW:
        return "FAIL", f"took {seconds:.1f} s"
    if caught:
        return "FAIL", f"warning escaped: {caught[0].category.__name__}: {caught[0].message}"
    return cls, msg


#: a message naming no cause ('(ReadError)'), or Python's words instead of the file's
VAGUE = re.compile(r"\((?:\w+Error|\w+Error, no reason given)\)|UnicodeDecodeError|could not convert string|"
                   r"invalid literal for|list index out of range|cannot reshape|codec can't|malformed node|"
                   r"TokenError|Errno")

_serial = count()


def _tally(label, cls, detail, data=None):
    TALLY[label, cls] += 1
    if cls == "FAIL" and len(FAILURES[label]) < 5:
        FAILURES[label].append((detail, data[:200] if data is not None else None))


def _judge(label, cls, detail, data=None):
    """Count the outcome; outside the counting mode a failure fails the example (hypothesis then shrinks it)."""
    _tally(label, cls, detail, data)
    if not COUNT:
        assert cls != "FAIL", f"{label}: {detail}"


def read_damaged(tmp_path, capfd, seed, data):
    """Write ``data`` under the seed's name in a new folder, read it, check nothing printed or left there."""
    folder = tmp_path / f"e{next(_serial)}"
    folder.mkdir()
    path = folder / seed.name
    path.write_bytes(data)
    capfd.readouterr()
    cls, detail = outcome(seed.reader, path)
    out, err = capfd.readouterr()
    if cls != "FAIL" and (out or err):
        cls, detail = "FAIL", f"printed {(out + err)[:200]!r}"
    left = sorted(p.name for p in folder.iterdir())
    if cls != "FAIL" and left != [seed.name]:
        cls, detail = "FAIL", f"left files {left}"
    shutil.rmtree(folder)
    return cls, detail


CASES = [(label, s) for label, seed in seeds().items() for s in strategies_for(seed)]


@pytest.fixture(scope="module", autouse=True)
def _table(request):
    """In the counting mode, print the table of inputs and outcomes by format and class."""
    yield
    if not COUNT:
        return
    capture = request.config.pluginmanager.get_plugin("capturemanager")
    with capture.global_and_fixture_disabled():
        print("\n" + "\n".join(table_lines()), flush=True)


def table_lines():
    """The counting mode's table: inputs by format (or command) and outcome class, then the failures."""
    lines = []
    for title, classes, cli in (("format", CLASSES, False), ("command", CLI_CLASSES, True)):
        labels = sorted({k[0] for k in TALLY if k[0].startswith("cli ") == cli})
        if not labels:
            continue
        width = max(len(label) for label in labels + [title])
        lines.append(f"{title:<{width}} {'inputs':>8} " + " ".join(f"{c:>11}" for c in classes))
        totals = Counter()
        for label in labels:
            row = {c: TALLY[label, c] for c in classes}
            totals.update(row)
            lines.append(f"{label:<{width}} {sum(row.values()):>8} " + " ".join(f"{row[c]:>11}" for c in classes))
        lines.append(f"{'total':<{width}} {sum(totals.values()):>8} "
                     + " ".join(f"{totals[c]:>11}" for c in classes))
    for label, fails in FAILURES.items():
        for detail, data in fails:
            lines.append(f"FAIL {label}: {detail} | {data!r}")
    return lines


# ---------------------------------------------------------------------------
# the readers
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("label", sorted(seeds()))
def test_every_seed_reads(tmp_path, capfd, label):
    """The undamaged files read back as valid results (else the fuzzing would test nothing)."""
    seed = seeds()[label]
    cls, detail = read_damaged(tmp_path, capfd, seed, seed.data)
    expected = "ReadError" if label in ("npz_str", "npy_str", "mask_npy_str") else (
        "SampleError" if label in ("npz_complex", "npy_complex") else "ok")
    assert (cls, label) == (expected, label), detail


@pytest.mark.parametrize("label,strategy", CASES, ids=[f"{a}-{b}" for a, b in CASES])
@FUZZ
@given(data=st.data())
def test_damaged_file_is_an_error_or_a_valid_result(tmp_path, capfd, label, strategy, data):
    seed = seeds()[label]
    damaged = data.draw(damage(seed, strategy), label="damaged")
    cls, detail = read_damaged(tmp_path, capfd, seed, damaged)
    _judge(label, cls, detail, damaged)


# ---------------------------------------------------------------------------
# the command line
# ---------------------------------------------------------------------------

#: damaged inputs of each command: (the argument damaged, seeds it is drawn from)
CLI_MESHES = ["ply_ascii", "ply_binary", "off", "obj", "stl_binary", "vtu_ours", "vtu_meshio_zlib", "vtp_pyvista",
              "vtk_pyvista_ascii", "vtk_ours", "vtu_nan", "ply_nan", "surf_gii", "freesurfer"]
CLI_SAMPLES = ["csv_vertex", "csv_xyz", "npz", "npz_compressed", "npy_struct", "func_gii", "label"]
CLI_CLOUDS = ["points_xyz", "points_csv", "points_ply_ascii", "points_ply_binary", "points_vtp_ours"]
CLI_CLASSES = ("exit 0", "exit 1", "exit 2", "FAIL")


def _volume_samples():
    """Positions (and values) on the digital surface of the voxel mask, as a CSV seed."""
    from manifill.solid.boundary import digital_surface

    _, P, _, _ = digital_surface(_mask(), spacing=[1.0, 1.0, 1.0], origin=[0.0, 0.0, 0.0], connectivity=6)
    rows = P[[0, len(P) // 3, len(P) // 2, len(P) - 1]]
    text = "x,y,z,t\n" + "".join(f"{a!r},{b!r},{c!r},{a + 2 * b!r}\n" for a, b, c in rows.tolist())
    return Seed("volume_csv", "s.csv", text.encode(), "cli", text=True)


def cli_inputs(command):
    """(argument position -> seeds it is drawn from) and the argv around them."""
    mesh, samples = [seeds()[k] for k in CLI_MESHES], [seeds()[k] for k in CLI_SAMPLES]
    if command == "info":
        return [mesh], ["info", 0]
    if command == "harmonic":
        return [mesh, samples], ["harmonic", 0, 1, "-o", "out.vtu"]
    if command == "check":
        return [mesh, samples], ["check", 0, 1]
    if command == "cloud":
        clouds = [seeds()[k] for k in CLI_CLOUDS]
        return [clouds, samples], ["reconstruct", 0, 1, "-o", "out.vtp", "--method", "harmonic", "-q"]
    return [[seeds()["mask_npy"]], [_volume_samples()]], ["volume", 0, 1, "-o", "out.vti", "-q"]


@st.composite
def cli_case(draw, command):
    """The seeds of every input of ``command``, one of them damaged."""
    choices, argv = cli_inputs(command)
    picked = [draw(st.sampled_from(c)) for c in choices]
    which = draw(st.integers(0, len(picked) - 1))
    seed = picked[which]
    strategy = draw(st.sampled_from(strategies_for(seed)))
    damaged = draw(damage(seed, strategy))
    return argv, picked, which, f"{seed.label}/{strategy}", damaged


def run_cli(tmp_path, capfd, argv, picked, which, damaged):
    """Run the command on the inputs (one damaged) in a new folder: (class, detail)."""
    folder = tmp_path / f"c{next(_serial)}"
    folder.mkdir()
    names = []
    for j, seed in enumerate(picked):
        name = f"in{j}_{seed.name}"  # two inputs never share a name
        (folder / name).write_bytes(damaged if j == which else seed.data)
        names.append(name)
    args = [str(folder / names[a]) if isinstance(a, int) else (str(folder / a) if a.startswith("out.") else a)
            for a in argv]
    out_name = next((a for a in argv if isinstance(a, str) and a.startswith("out.")), None)
    reader = read_vti if out_name and out_name.endswith(".vti") else (lambda p: read_mesh_file(p, points=True))
    result = run_command(capfd, folder, args, names, [out_name] if out_name else [], reader,
                         check=argv[0] == "check", most_memory=MOST_MEMORY)
    shutil.rmtree(folder)
    return result


@pytest.mark.parametrize("command", ["info", "harmonic", "check", "volume", "cloud"])
def test_cli_seeds_run(tmp_path, capfd, command):
    """The undamaged inputs run to exit 0 (else the command fuzzing would test only refusals)."""
    choices, argv = cli_inputs(command)
    for k in range(max(len(c) for c in choices)):
        picked = [c[k % len(c)] for c in choices]
        refused = picked[0].label in ("vtu_nan", "ply_nan") or (  # NaN points; STL renumbers the vertices
            picked[0].label == "stl_binary" and command != "info" and picked[1].label != "csv_xyz")
        expected = ("exit 2" if refused else "exit 0", "")
        assert run_cli(tmp_path, capfd, argv, picked, -1, b"") == expected, [s.label for s in picked]


@pytest.mark.parametrize("command", ["info", "harmonic", "check", "volume", "cloud"])
@CLI_FUZZ
@given(case=st.data())
def test_cli_on_a_damaged_input_exits_0_or_2_with_one_line(tmp_path, capfd, command, case):
    argv, picked, which, label, damaged = case.draw(cli_case(command), label="case")
    cls, detail = run_cli(tmp_path, capfd, argv, picked, which, damaged)
    _judge(f"cli {command}", cls, f"{label}: {detail}", damaged)


# ---------------------------------------------------------------------------
# regressions: one per class of failure the fuzzing found
# ---------------------------------------------------------------------------


def _read_error(path, reader=read_mesh_file, *args):
    """The one-line ReadError (or other manifill error) ``reader`` raises on ``path``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises((ReadError, SampleError, MeshError)) as info:
            reader(path, *args)
    assert not caught, [str(w.message) for w in caught]
    msg = str(info.value)
    assert "\n" not in msg and path.name in msg, msg
    return msg


def _ends(fn, *args, limit=60.0):
    """``fn(*args)`` in a daemon thread: its result, or a test failure if it is still running after ``limit`` s.

    A reader that loops forever then fails its test instead of stopping the suite (the thread is left behind).
    """
    import threading

    box = {}

    def run():
        try:
            box["value"] = fn(*args)
        except BaseException as exc:  # noqa: BLE001 - handed to the test
            box["error"] = exc

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    worker.join(limit)
    if worker.is_alive():
        pytest.fail(f"{getattr(fn, '__name__', fn)} still running after {limit:.0f} s: it hangs")
    if "error" in box:
        raise box["error"]
    return box["value"]


def test_regression_ply_header_without_end_never_hangs(tmp_path, capfd):
    # meshio's PLY reader looked for 'end_header' past the end of the file forever
    data = seeds()["ply_binary"].data
    cut = data.index(b"end_header")
    for k in (3, data.index(b"element vertex") + 5, cut, cut + 5):
        path = tmp_path / f"cut{k}.ply"
        path.write_bytes(data[:k])
        assert "end_header" in _ends(_read_error, path)
    assert capfd.readouterr() == ("", "")


def test_regression_lying_ply_counts(tmp_path):
    # meshio allocates for the faces a header claims before finding the file short (2**31 of them: 16 GB); the
    # counts here are small enough to fail fast where the check is missing
    data = seeds()["ply_binary"].data
    for old, new in ((b"element face 80", b"element face 50000"), (b"element vertex 42", b"element vertex 4200"),
                     (b"element face 80", b"element face 1e9")):
        path = tmp_path / "lie.ply"
        path.write_bytes(data.replace(old, new))
        msg = _read_error(path)
        assert "header" in msg and ("claims" in msg or "gives no count" in msg), msg
    # the true counts still read, in both encodings
    for label in ("ply_ascii", "ply_binary"):
        path = tmp_path / f"{label}.ply"
        path.write_bytes(seeds()[label].data)
        assert read_mesh_file(path).F.shape == F_SPHERE.shape


@pytest.mark.parametrize("label,old,new", [
    ("off", b"\n3 40 19 20\n", b"\n3 40 19 4294967296\n"),  # meshio keeps what the file says
    ("obj", b"\nf 41 20 21\n", b"\nf 41 20 2147483648\n"),
    ("obj", b"\nf 41 20 21\n", b"\nf 41 20 0\n"),  # OBJ counts from 1: 0 is vertex -1
    ("freesurfer", None, None),
])
def test_regression_face_index_beyond_the_points(tmp_path, label, old, new):
    seed = seeds()[label]
    data = bytearray(seed.data)
    if old is None:  # FreeSurfer: the first corner of the first triangle, big-endian int32 after the 42 points
        start = data.index(b"\n\n") + 2 + 8 + 42 * 12
        data[start:start + 4] = (297).to_bytes(4, "big")
    else:
        assert old in data
        data = data.replace(old, new, 1)
    path = tmp_path / seed.name
    path.write_bytes(bytes(data))
    assert "uses vertex" in _read_error(path)


def test_regression_ply_points_of_wrong_shape(tmp_path):
    # with its properties reordered (x, z, y) meshio returned (n, 1) points
    path = tmp_path / "m.ply"
    path.write_bytes(seeds()["ply_ascii"].data.replace(b"property double y\nproperty double z",
                                                       b"property double z\nproperty double y"))
    assert "not (n, 3)" in _read_error(path)


def test_regression_tet_index_beyond_the_points(tmp_path):
    # meshio's VTU reader returns the connectivity as stored
    TV, TT = _cube_tets()
    TT[2, 3] = 99
    path = tmp_path / "t.vtu"
    _quiet(meshio.write, path, meshio.Mesh(TV, [("tetra", TT)]), binary=False)
    assert "tetrahedron 2 uses vertex 99 but the file has 8 vertices" in _read_error(path, read_tets)


def test_regression_lying_npy_mask_header(tmp_path):
    # read_mask called np.load directly: MemoryError for a lying shape, EOFError and TokenError for cut headers
    data = seeds()["mask_npy"].data
    for name, damaged in (("huge.npy", data.replace(b"(6, 6, 6)", b"(2147483648, 6, 6)")),
                          ("cut.npy", data[:30]), ("empty.npy", b""),
                          ("overflow.npy", data.replace(b"(6, 6, 6)", b"(6, 9223372036854775808, 6)"))):
        path = tmp_path / name
        path.write_bytes(damaged)
        msg = _read_error(path, read_mask)
        assert "memory" not in msg.lower()
    assert "header claims" in _read_error(tmp_path / "huge.npy", read_mask)


def test_regression_empty_or_text_npy_mask(tmp_path):
    for name, arr in (("empty.npy", np.zeros((6, 6, 0), dtype=bool)), ("text.npy", np.full((2, 2, 2), "1")),
                      ("pairs.npy", np.zeros((2, 2, 2), dtype=[("a", "u1"), ("b", "u1")]))):
        np.save(tmp_path / name, arr)
        assert "not a 3-D mask" in _read_error(tmp_path / name, read_mask)
    np.save(tmp_path / "ok.npy", np.ones((2, 2, 2), dtype=np.uint8))  # 0/1 numbers still read
    assert read_mask(tmp_path / "ok.npy")[0].all()


def test_regression_sample_errors_name_the_file(tmp_path):
    # the checks of Samples spoke of 'idx' without saying which file was wrong
    (tmp_path / "far.csv").write_text("vertex,t\n2147483648,1\n")
    assert "far.csv: " in _read_error(tmp_path / "far.csv", read_samples, V_SPHERE)
    (tmp_path / "away.csv").write_text("x,y,z,t\n40,0,0,1\n")
    assert "wrong units" in _read_error(tmp_path / "away.csv", read_samples, V_SPHERE)
    (tmp_path / "twice.csv").write_text("vertex,t\n3,1\n3,2\n")
    assert _read_error(tmp_path / "twice.csv", read_samples, V_SPHERE).startswith("twice.csv: ")


def test_regression_meshio_notes_not_printed(tmp_path, capfd):
    # meshio prints 'Warning: $MeshFormat not closed by $EndMeshFormat.' to stderr itself, not as a warning
    path = tmp_path / "t.msh"
    path.write_bytes(seeds()["tets_msh_ascii"].data.replace(b"$EndMeshFormat", b"$End"))
    try:
        read_tets(path)
    except ReadError:
        pass
    assert capfd.readouterr() == ("", "")


def test_regression_nibabel_log_not_printed(tmp_path, capfd):
    # nibabel logs 'Unknown MGH format version' through a stream handler of its own (on the real stderr)
    path = tmp_path / "d.mgh"
    path.write_bytes(b"\x01" + seeds()["mgh"].data[1:])
    with LogRecords() as logged:
        _read_error(path, read_samples, V_SPHERE)
    assert not logged and capfd.readouterr() == ("", "")


def test_regression_unclosed_file_warning(tmp_path):
    # nibabel leaves the file of a failed MGH read open: its ResourceWarning came after the ReadError, at collection
    import gc

    path = tmp_path / "d.mgh"
    path.write_bytes(seeds()["mgh"].data[:40])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(ReadError):
            read_samples(path, V_SPHERE)
        gc.collect()
    assert not [w for w in caught if issubclass(w.category, ResourceWarning)]


def test_regression_gifti_huge_dimensionality(tmp_path):
    # nibabel counted up to Dimensionality looking for Dim attributes: 10**30 never ends
    data = seeds()["func_gii"].data
    assert b'Dimensionality="1"' in data
    for value in (b"7", b"1" + b"0" * 30):
        path = tmp_path / "d.func.gii"
        path.write_bytes(data.replace(b'Dimensionality="1"', b'Dimensionality="' + value + b'"'))
        assert "Dimensionality" in _ends(_read_error, path, read_samples, V_SPHERE)


def test_regression_truncated_label_row(tmp_path):
    # a row cut after its y coordinate gave that coordinate as the value; a label of one row had no length
    data = seeds()["label"].data
    lines = data.split(b"\n")
    for name, damaged, words in (("cut.label", b"\n".join([lines[0], b"1", lines[2][:16]]), "not 5"),
                                 ("short.label", b"\n".join(data.split(b"\n")[:4]) + b"\n", "claims 5"),
                                 ("count.label", data.replace(b"\n5\n", b"\nfive\n"), "number of vertices")):
        path = tmp_path / name
        path.write_bytes(damaged)
        assert words in _read_error(path, read_samples, V_SPHERE)
    (tmp_path / "one.label").write_bytes(b"\n".join([lines[0], b"1", lines[2]]) + b"\n")
    S = read_samples(tmp_path / "one.label", V_SPHERE)
    assert S.idx.tolist() == [SAMPLE_VERTICES[0]] and S.vals.shape == (1, 1)


def test_regression_positions_on_a_mesh_with_nan_points(tmp_path, capfd):
    # snapping positions to a mesh with NaN points ended in scipy's ValueError: an internal error of the CLI
    (tmp_path / "s.csv").write_text("x,y,z,t\n0,0,1,1\n")
    bad = V_SPHERE.copy()
    bad[3] = np.nan
    with pytest.raises(MeshError, match=r"s\.csv: .*NaN or infinite coordinates \(vertex 3\)"):
        read_samples(tmp_path / "s.csv", bad)
    cls, detail = run_cli(tmp_path, capfd, ["harmonic", 0, 1, "-o", "out.vtu"],
                          [seeds()["vtu_nan"], seeds()["npz_compressed"]], -1, b"")
    assert (cls, detail) == ("exit 2", "")


def test_regression_lying_mgh_header(tmp_path):
    # nibabel allocates width x height x depth x frames values before finding the file short (1 GB here)
    import gzip

    data = bytearray(seeds()["mgh"].data)
    data[4:8] = (2**28).to_bytes(4, "big")
    (tmp_path / "d.mgh").write_bytes(bytes(data))
    (tmp_path / "d.mgz").write_bytes(gzip.compress(bytes(data)))
    for name in ("d.mgh", "d.mgz"):
        assert "header claims 268435456 x 1 x 1 x 1 values" in _read_error(tmp_path / name, read_samples, V_SPHERE)
    (tmp_path / "ok.mgz").write_bytes(gzip.compress(seeds()["mgh"].data))  # the true header still reads
    assert read_samples(tmp_path / "ok.mgz", V_SPHERE).idx.tolist() == SAMPLE_VERTICES


def test_regression_lying_npy_header(tmp_path):
    # numpy reads the header length an NPY file gives in one read: a damaged version byte or length asked for GBs
    data = seeds()["npy_struct"].data
    v2 = data[:6] + b"\x02\x00" + (2**31).to_bytes(4, "little") + data[10:]
    for name, damaged in (("v2.npy", v2), ("version.npy", data[:6] + data[7:]),
                          ("short.npy", data[:8] + (0xFFFF).to_bytes(2, "little") + data[10:])):
        (tmp_path / name).write_bytes(damaged)
        with peak_memory() as peak:
            msg = _read_error(tmp_path / name, read_samples, V_SPHERE)
        assert peak[0] < MOST_MEMORY and ("header claims" in msg or "version" in msg), msg
    import zipfile

    member = io.BytesIO()
    np.save(member, np.arange(3))
    lie = member.getvalue()[:8] + b"\xff\xff" + member.getvalue()[10:]  # with its CRC: only the length lies
    with zipfile.ZipFile(tmp_path / "s.npz", "w") as zf:
        zf.writestr("idx.npy", lie)
        zf.writestr("vals.npy", member.getvalue())
    assert "header claims 65,535 header bytes" in _read_error(tmp_path / "s.npz", read_samples, V_SPHERE)


def test_regression_lying_gmsh_counts(tmp_path):
    # meshio's Gmsh reader calls numpy.fromfile with the counts a file gives (64 GB for 2**31 nodes) and reads
    # as many tag lines as a $NodeData section claims (10**30: never ends)
    text = seeds()["tets_msh_ascii"].data
    huge_nodes = text.replace(b"$Nodes\n8\n", b"$Nodes\n2147483648\n")
    data = (b'$NodeData\n1\n"u"\n' + b"1" + b"0" * 30 + b"\n0.0\n3\n0\n1\n8\n"
            + b"".join(b"%d 0.5\n" % (i + 1) for i in range(8)) + b"$EndNodeData\n")
    binary = bytearray(seeds()["tets_msh_binary"].data)
    k = binary.index(b"$Elements\n") + len(b"$Elements\n5\n")
    binary[k + 8:k + 12] = (2**30).to_bytes(4, "little")  # the tags of the first element block
    for name, damaged, words in (("nodes.msh", huge_nodes, "claims 2,147,483,648 nodes"),
                                 ("data.msh", text + data, "real tags of $NodeData"),
                                 ("tags.msh", bytes(binary), "elements in a block")):
        (tmp_path / name).write_bytes(damaged)
        with peak_memory() as peak:
            msg = _ends(_read_error, tmp_path / name, read_tets)
        assert words in msg and peak[0] < MOST_MEMORY, (msg, peak[0])
