"""Fuzzing the newer inputs through the command line: globe tables and netCDF, batch manifests and their options,
time-series tables, point clouds at extreme scales and in clusters.

Valid seeds are built in code, then damaged by :mod:`fuzzing`'s strategies (truncation, byte flips, insertions,
numbers replaced by huge, negative or non-numeric ones, lines duplicated or deleted) and run with options drawn
from valid and invalid values (``--grid``, ``--var``, ``--method``, ``--memory-limit``, ``--workers``, ...); clouds
are drawn at scales 1e-320..1e320 and with clusters of up to 600 points within 1e-15..1e-1 of one point. Every run
ends as :func:`fuzzing.run_command` demands (exit 0 or 2 with one line, no internal error, traceback, warning, hang
or file left half-written) and, where it ends well, its output is read back and checked: a netCDF with the grid's
shape and values within the stations' range widened by its span; a series of complete steps; a cloud's field finite
and within its samples' range widened by ten spans (a field 1e14 times its samples' is wrong without a word);
a batch summary whose every row is done with its output, or failed/refused with one line.

CI runs a short selection (``EXAMPLES`` per command, about 30 s). ``MANIFILL_FUZZ_COUNT=N`` runs N per command and
prints the table of inputs and outcomes at the end (the benchmark figures in docs/benchmarks.md):
``MANIFILL_FUZZ_COUNT=400 pytest tests/io/test_fuzz_new_inputs.py -p no:cacheprovider -s``.
"""

import os
import shutil
import xml.etree.ElementTree as ET
from collections import Counter, defaultdict
from itertools import count

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzing import Seed, damage, run_command, strategies_for
from manifill.errors import ReadError
from manifill.io import read_mesh_file, write_mesh
from manifill.mesh.shapes import icosphere

pd = pytest.importorskip("pandas", reason="the [xarray] extra (pandas) is not installed")
xr = pytest.importorskip("xarray", reason="the [xarray] extra is not installed")
pytest.importorskip("netCDF4", reason="the [xarray] extra (netCDF4) is not installed")

COUNT = int(os.environ.get("MANIFILL_FUZZ_COUNT", "0") or 0)
EXAMPLES = COUNT or 8
FUZZ = settings(derandomize=True, database=None, max_examples=EXAMPLES, deadline=None, print_blob=False,
                suppress_health_check=list(HealthCheck))
CLASSES = ("exit 0", "exit 1", "exit 2", "FAIL")
TALLY = Counter()
FAILURES = defaultdict(list)
_serial = count()

V, F = icosphere(2)
IDX = np.arange(0, len(V), 9)
VALS = np.sin(2 * V[IDX, 0]) + V[IDX, 1] * V[IDX, 2]


def _stations():
    rng = np.random.default_rng(0)
    k = 40
    lon, lat = rng.uniform(-180, 180, k), np.degrees(np.arcsin(rng.uniform(-1, 1, k)))
    la, lo = np.radians(lat), np.radians(lon)
    t = np.sin(2 * np.cos(la) * np.cos(lo)) + np.cos(la) * np.sin(lo) * np.sin(la)
    return lon, lat, t


def _build(folder):
    """The valid seeds, written by the writers our users use: ``{label: Seed}``."""
    lon, lat, t = _stations()
    out = {}

    def add(label, name, write, text):
        path = folder / name
        write(path)
        out[label] = Seed(label, name, path.read_bytes(), "cli", text=text)

    add("globe_csv", "st.csv", lambda p: pd.DataFrame({"lon": lon, "lat": lat, "name": [f"s{i}" for i in range(len(t))],
                                                     "t1": t, "t2": 2 * t + 1}).to_csv(p, index=False), True)
    add("globe_nc", "st.nc", lambda p: xr.Dataset(
        {"temp": (("station", "time"), np.column_stack([t, t + 1, t - 1]), {"units": "K"})},
        coords={"lon": ("station", lon), "lat": ("station", lat), "time": np.arange(3)}).to_netcdf(p), False)
    add("mesh", "m.ply", lambda p: write_mesh(p, V, F), False)
    vertex = "vertex,value\n" + "".join(f"{i},{float(v)!r}\n" for i, v in zip(IDX, VALS))
    add("samples", "s.csv", lambda p: p.write_text(vertex), True)
    add("manifest_csv", "jobs.csv", lambda p: p.write_text(
        "id,mesh,samples,output,options\na,m.ply,s.csv,o1.vtu,\nb,m.ply,s.csv,o2.vtu,--method harmonic\n"), True)
    add("manifest_toml", "jobs.toml", lambda p: p.write_text(
        '[[job]]\nid = "a"\nmesh = "m.ply"\nsamples = "s.csv"\noutput = "o1.vtu"\n\n'
        '[[job]]\nid = "b"\nmesh = "m.ply"\nsamples = "s.csv"\noutput = "o2.vtu"\noptions = "--method harmonic"\n'),
        True)
    steps = np.column_stack([VALS * (1 + 0.1 * j) for j in range(4)])
    add("series_wide", "series.csv", lambda p: p.write_text(
        "vertex,t0,t1,t2,t3\n" + "".join(f"{i}," + ",".join(f"{float(x)!r}" for x in row) + "\n"
                                         for i, row in zip(IDX, steps))), True)
    add("series_long", "long.csv", lambda p: p.write_text(
        "vertex,time,value\n" + "".join(f"{i},{j * 0.5!r},{float(steps[r, j])!r}\n"
                                        for j in range(4) for r, i in enumerate(IDX))), True)
    return out


_SEEDS = {}


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    if not _SEEDS:
        _SEEDS.update(_build(tmp_path_factory.mktemp("seeds")))
    return _SEEDS


def _judge(label, cls, detail, data=None):
    TALLY[label, cls] += 1
    if cls == "FAIL" and len(FAILURES[label]) < 5:
        FAILURES[label].append((detail, data[:200] if isinstance(data, bytes) else data))
    if not COUNT:
        assert cls != "FAIL", f"{label}: {detail}"


@pytest.fixture(scope="module", autouse=True)
def _table(request):
    """In the counting mode, print the table of inputs and outcomes by command and class."""
    yield
    if not COUNT:
        return
    labels = sorted({k[0] for k in TALLY})
    width = max([len(x) for x in labels] + [7])
    lines = [f"{'command':<{width}} {'inputs':>8} " + " ".join(f"{c:>8}" for c in CLASSES)]
    totals = Counter()
    for label in labels:
        row = {c: TALLY[label, c] for c in CLASSES}
        totals.update(row)
        lines.append(f"{label:<{width}} {sum(row.values()):>8} " + " ".join(f"{row[c]:>8}" for c in CLASSES))
    lines.append(f"{'total':<{width}} {sum(totals.values()):>8} " + " ".join(f"{totals[c]:>8}" for c in CLASSES))
    lines += [f"FAIL {label}: {d} | {data!r}" for label, fails in FAILURES.items() for d, data in fails]
    capture = request.config.pluginmanager.get_plugin("capturemanager")
    with capture.global_and_fixture_disabled():
        print("\n" + "\n".join(lines), flush=True)


def _folder(tmp_path, files):
    folder = tmp_path / f"f{next(_serial)}"
    folder.mkdir()
    for name, data in files.items():
        (folder / name).write_bytes(data)
    return folder


# ---------------------------------------------------------------------------
# the globe
# ---------------------------------------------------------------------------

GRIDS = ["20", "10", "30", "7", "0", "-5", "nan", "inf", "1e-9", "0.1", "0.05", "90", "180", "360", "abc", "1e400"]
VALID_GRIDS = ["20", "10", "30", "15", "45", "60"]
VARS = [None, None, None, "t1", "t2", "temp", "name", "lon", "nope", "", "T1"]
METHODS = [None, "default", "biharmonic", "harmonic", "gvf-harmonic", "gvf", "rbf", "gp", "hessian", "auto", "nope"]


def _station_range(path):
    """The range of the numbers the stations file holds, as read (a damaged number may be 1e308)."""
    try:
        if path.suffix == ".csv":
            table = pd.read_csv(path)
            a = table.drop(columns=[c for c in ("lon", "lat") if c in table]).apply(pd.to_numeric, errors="coerce")
            a = a.to_numpy(dtype=np.float64)
        else:
            with xr.open_dataset(path) as ds:
                a = np.concatenate([np.ravel(ds[v].values).astype(np.float64) for v in ds.data_vars
                                    if ds[v].dtype.kind in "iuf"])
    except Exception:  # noqa: BLE001 - unreadable here: only finiteness is checked
        return -np.inf, np.inf
    a = a[np.isfinite(a)]
    return (float(a.min()), float(a.max())) if a.size else (-np.inf, np.inf)


def _netcdf_back(path, lo, hi, spans):
    """The netCDF reads back with the grid's dimensions, its values within the stations' range widened by ``spans``
    of it (0 for the default, which keeps the range; an unbounded method's field may overshoot)."""
    ds = xr.open_dataset(path)
    try:
        (name,) = list(ds.data_vars)
        a = np.asarray(ds[name].values, dtype=np.float64)
        assert ds[name].dims[-2:] == ("lat", "lon"), ds[name].dims
        pad = spans * (hi - lo) + 1e-9 * max(abs(lo), abs(hi), 1.0)
        ok = a[np.isfinite(a)]
        if ok.size and not (ok.min() >= lo - pad and ok.max() <= hi + pad):
            raise ReadError(f"values in [{ok.min():.3g}, {ok.max():.3g}] for stations in [{lo:.3g}, {hi:.3g}]")
    finally:
        ds.close()


@st.composite
def globe_case(draw, seeds):
    label = draw(st.sampled_from(["globe_csv", "globe_nc"]))
    seed = seeds[label]
    strategy = draw(st.sampled_from(["none", "none", "none", *strategies_for(seed)]))
    data = seed.data if strategy == "none" else draw(damage(seed, strategy))
    opts = ["--grid", draw(st.one_of(st.sampled_from(VALID_GRIDS), st.sampled_from(GRIDS)))]
    var, method = draw(st.sampled_from(VARS)), draw(st.sampled_from(METHODS))
    opts += [] if var is None else ["--var", var]
    opts += [] if method is None else ["--method", method]
    opts += draw(st.sampled_from([[], [], [], ["--lon", "lat"], ["--lat", "nope"], ["--lon", "t1"],
                                  ["--smoothing", "auto"], ["--smoothing", "-1"]]))
    return label, strategy, data, opts


@FUZZ
@given(case=st.data())
def test_globe_on_damaged_tables_and_options(tmp_path, capfd, seeds, case):
    label, strategy, data, opts = case.draw(globe_case(seeds), label="case")
    name = seeds[label].name
    folder = _folder(tmp_path, {name: data})
    lo, hi = _station_range(folder / name)
    bounded = "--method" not in opts or opts[opts.index("--method") + 1] == "default"

    def read_back(path):
        return _netcdf_back(path, lo, hi, 0.0 if bounded else 10.0)

    cls, detail = run_command(capfd, folder, ["globe", folder / name, "-o", folder / "out.nc", *opts], [name],
                              ["out.nc"], read_back, slow=30.0, most_memory=1 << 40)
    shutil.rmtree(folder)
    _judge(f"globe {label}", cls, f"{strategy} {opts}: {detail}", data)


# ---------------------------------------------------------------------------
# batches
# ---------------------------------------------------------------------------

LIMITS = [None, None, "4GB", "1MB", "100MB", "0", "abc", "-1GB", "1e3", "auto", "300MB", "1TB", "1.5GB", "GB"]
WORKERS = ["1", "1", "0", "-1", "abc", "2.5"]


def _summary_outputs(folder):
    """The summary and the outputs its rows name (a damaged manifest may name others than o1.vtu, o2.vtu)."""
    summary = folder / "jobs.summary.csv"
    if not summary.exists():
        return ["jobs.summary.csv"]
    rows = pd.read_csv(summary, dtype=str, keep_default_na=False).to_dict("records")
    return ["jobs.summary.csv", *(os.path.basename(r["output"]) for r in rows)]


def _batch_back(folder):
    """The summary's rows agree with the outputs: done with a complete output, else one line and no output."""
    import meshio

    summary = folder / "jobs.summary.csv"
    if not summary.exists():
        return
    rows = pd.read_csv(summary, dtype=str, keep_default_na=False).to_dict("records")
    for r in rows:
        out = folder / os.path.basename(r["output"])
        if r["status"] == "done":
            if not np.isfinite(meshio.read(out).point_data["value"]).all():
                raise ReadError(f"job {r['id']}: non-finite values")
        elif out.exists() and r["status"] != "skipped":
            raise ReadError(f"job {r['id']} is {r['status']} but its output exists")
        elif r["status"] in ("failed", "refused") and ("\n" in r["error"] or not r["error"].strip()):
            raise ReadError(f"job {r['id']}: error {r['error']!r}")


@st.composite
def batch_case(draw, seeds):
    label = draw(st.sampled_from(["manifest_csv", "manifest_toml", "mesh", "samples"]))
    seed = seeds[label]
    strategy = draw(st.sampled_from(["none", *strategies_for(seed)]))
    data = seed.data if strategy == "none" else draw(damage(seed, strategy))
    manifest = draw(st.sampled_from(["manifest_csv", "manifest_toml"])) if label not in (
        "manifest_csv", "manifest_toml") else label
    opts = ["--workers", draw(st.sampled_from(WORKERS))]
    limit = draw(st.sampled_from(LIMITS))
    opts += [] if limit is None else [f"--memory-limit={limit}"]
    return label, manifest, strategy, data, opts


def test_batch_seed_runs(tmp_path, capfd, seeds):
    """The undamaged manifest runs its two jobs to exit 0 (else the fuzzing would test only refusals)."""
    files = {s.name: s.data for k, s in seeds.items() if k in ("mesh", "samples", "manifest_csv")}
    folder = _folder(tmp_path, files)
    cls, detail = run_command(capfd, folder, ["batch", folder / "jobs.csv", "--workers", "1"], list(files),
                              ["o1.vtu", "o2.vtu"], lambda p: None, extra_files=("jobs.summary.csv",), slow=60.0,
                              most_memory=1 << 40)
    assert (cls, detail) == ("exit 0", ""), detail
    _batch_back(folder)


@settings(FUZZ, max_examples=COUNT or 4)
@given(case=st.data())
def test_batch_on_damaged_manifests_inputs_and_options(tmp_path, capfd, seeds, case):
    label, manifest, strategy, data, opts = case.draw(batch_case(seeds), label="case")
    files = {seeds[k].name: seeds[k].data for k in ("mesh", "samples", manifest)}
    files[seeds[label].name] = data
    folder = _folder(tmp_path, files)
    cls, detail = run_command(capfd, folder, ["batch", folder / seeds[manifest].name, *opts], list(files),
                              [], lambda p: None, exit1=True, slow=60.0, most_memory=1 << 40,
                              extra_files=_summary_outputs)
    if cls != "FAIL":
        try:
            _batch_back(folder)
        except (ReadError, KeyError, ValueError, OSError) as exc:
            cls, detail = "FAIL", f"summary and outputs disagree: {exc}"
    shutil.rmtree(folder)
    _judge(f"batch {label}", cls, f"{strategy} {opts}: {detail}", data)


# ---------------------------------------------------------------------------
# time-series tables
# ---------------------------------------------------------------------------


def _series_back(path):
    import meshio

    steps = [d.get("file") for d in ET.parse(path).getroot().iter("DataSet")]
    if not steps:
        raise ReadError("a series of no steps")
    for f in steps:
        data = meshio.read(path.parent / f).point_data
        if not all(np.isfinite(a).all() for a in data.values()):
            raise ReadError(f"{f}: non-finite values")


@FUZZ
@given(case=st.data())
def test_series_on_damaged_tables(tmp_path, capfd, seeds, case):
    label = case.draw(st.sampled_from(["series_wide", "series_long"]))
    seed = seeds[label]
    strategy = case.draw(st.sampled_from(strategies_for(seed)))
    data = case.draw(damage(seed, strategy))
    method = case.draw(st.sampled_from([[], ["--method", "harmonic"], ["--method", "gvf-harmonic"]]))
    folder = _folder(tmp_path, {"m.ply": seeds["mesh"].data, seed.name: data})
    cls, detail = run_command(capfd, folder, ["reconstruct", folder / "m.ply", folder / seed.name, "-o",
                                              folder / "out.pvd", "-q", *method], ["m.ply", seed.name],
                              ["out.pvd"], _series_back, extra_files=("out",), slow=30.0, most_memory=1 << 40)
    shutil.rmtree(folder)
    _judge(f"series {label}", cls, f"{strategy}: {detail}", data)


# ---------------------------------------------------------------------------
# point clouds at extreme scales and in clusters
# ---------------------------------------------------------------------------

CLOUD_METHODS = ["default", "harmonic", "biharmonic", "triharmonic", "gvf-harmonic", "rbf", "gp"]


def _cloud_back(lo, hi):
    def check(path):
        x = np.asarray(read_mesh_file(path, points=True).point_data["value"], dtype=np.float64)
        span = max(hi - lo, 1e-300)
        if not (np.isfinite(x).all() and x.min() >= lo - 10 * span and x.max() <= hi + 10 * span):
            raise ReadError(f"values in [{np.nanmin(x):.3g}, {np.nanmax(x):.3g}] for samples in [{lo:.3g}, {hi:.3g}]")
    return check


@st.composite
def cloud_case(draw):
    e = draw(st.one_of(st.floats(-320, 320), st.sampled_from([-200.0, -160.0, -80.0, -8.0, 0.0, 8.0, 80.0, 160.0,
                                                              200.0, 300.0])))
    n = draw(st.sampled_from([0, 0, 2, 20, 600]))
    radius = 10.0 ** draw(st.floats(-15, -1))
    method = draw(st.sampled_from(CLOUD_METHODS))
    command = draw(st.sampled_from(["reconstruct", "reconstruct --gradient", "cv"]))
    return e, n, radius, method, command


@FUZZ
@given(case=cloud_case())
def test_clouds_at_extreme_scales_and_in_clusters(tmp_path, capfd, case):
    e, n, radius, method, command = case
    rng = np.random.default_rng(int(abs(e) * 1000) % 2**32)
    P = np.vstack([V, V[0] + radius * rng.normal(size=(n, 3))])
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        P = P * np.power(10.0, e)
    folder = tmp_path / f"f{next(_serial)}"
    folder.mkdir()
    np.savetxt(folder / "c.xyz", P)
    (folder / "s.csv").write_text("vertex,value\n" + "".join(f"{i},{float(v)!r}\n" for i, v in zip(IDX, VALS)))
    if command == "cv":
        argv, outputs = ["cv", folder / "c.xyz", folder / "s.csv", "--methods", method], []
    else:
        argv = ["reconstruct", folder / "c.xyz", folder / "s.csv", "-o", folder / "out.vtp", "--method", method,
                "-q", *command.split()[1:]]
        outputs = ["out.vtp"]
    cls, detail = run_command(capfd, folder, argv, ["c.xyz", "s.csv"], outputs, _cloud_back(VALS.min(), VALS.max()),
                              slow=30.0, most_memory=1 << 40)
    shutil.rmtree(folder)
    _judge(f"cloud {command}", cls, f"x1e{e:.3g}, cluster {n} in {radius:.1e}, {method}: {detail}")
