"""``manifill reconstruct MESH SAMPLES -o OUT.xdmf|.pvd|.h5``: a time series, chunk by chunk of time steps.

The samples hold one value per time step (:func:`manifill.io.series.read_series`: many value
columns, a ``time`` column, or one file per step); a :class:`manifill.Reconstructor` is prepared
once and applied to a chunk of steps at a time, each chunk written at once
(:class:`manifill.io.series_write.SeriesWriter`), so memory does not grow with the number of
steps. The output is all or nothing: an error or Ctrl-C leaves no file. ``--workers N`` (a Dask
``LocalCluster`` of N processes, one thread each) or ``--scheduler ADDRESS`` (an existing
cluster; else ``DASK_SCHEDULER_ADDRESS`` when set) applies the chunks on Dask workers, written
here in time order: the same file.
"""

import glob
import zipfile
from pathlib import Path

from ..errors import OptionError
from ..io import read_mesh_file
from ..io.distributed import dask_client
from ..io.formats import FormatView, find_format
from ..io.series import TIME_COLUMNS, read_series, series_only
from ..io.stream import chunk_size, reconstruct_series
from ..progress import StepBar
from .common import check_barrier_numbering, check_order, print_time
from .options import check_workers

__all__ = ["SERIES_OUTPUTS", "is_series", "run_series"]

#: Outputs that make ``reconstruct`` write a time series (``.npy`` and ``.gii`` too, when the samples are one).
SERIES_OUTPUTS = FormatView("series", writing=True)


def is_series(samples, out, chunk=None):
    """Whether ``reconstruct`` reads ``samples`` as a time series: a series output, ``--chunk``, a folder or a
    glob pattern of per-time files, an NPZ with ``times``, or a CSV whose first value column is ``time``."""
    p = Path(samples)
    if series_only(out) or p.is_dir() or chunk is not None:
        return True
    fmt = find_format("samples", p)
    if fmt is not None and fmt.times and p.is_file():  # a NumPy archive with its 'times'?
        try:
            with zipfile.ZipFile(p) as z:
                return "times.npy" in z.namelist()
        except (OSError, zipfile.BadZipFile):
            return False  # the reader says what is wrong with it
    if not p.exists() and any(c in str(samples) for c in "*?["):
        return bool(glob.glob(str(samples)))
    if fmt is not None and fmt.text and p.is_file():
        with open(p, encoding="utf-8", errors="replace") as fh:
            head = [h.strip().lower() for h in fh.readline().split(",")]
        first = 1 if head and head[0] in ("vertex", "idx", "index", "vertex_id", "id") else 3
        return len(head) > first and head[first] in TIME_COLUMNS
    return False


def run_series(args, out, options, exact):
    """Read the series, then :func:`manifill.io.stream.reconstruct_series`; print a summary."""
    for flag in ("render", "html", "subdivide", "clean"):
        if getattr(args, flag, None):
            raise OptionError(f"--{flag} is not available for a time series; leave it out (open the series in "
                              f"ParaView instead)")
    check_order(args.mesh, args.samples)
    mesh = read_mesh_file(args.mesh, points=True)
    V, F = mesh.V, mesh.F
    check_barrier_numbering(mesh, options["options"].fill.barriers)
    series = read_series(args.samples, V, duplicates=args.duplicates, max_distance=args.max_distance,
                         vertex_numbering=mesh.vertex_numbering, keep_points=exact)
    S, T = series.samples, series.steps
    where = dict(idx=S.idx, vals=S.vals) if S.points is None else dict(idx=S.points, vals=S.point_vals,
                                                                         max_distance=args.max_distance)
    step = chunk_size(len(V), T, args.chunk)
    chunks = -(-T // step)
    print(f"{len(V):,} vertices, {len(where['vals']):,} samples, {T:,} time steps of {series.names[0]!r} "
          f"({series.times[0]:g} .. {series.times[-1]:g}, times from {series.times_from}), in {chunks} chunk(s) "
          f"of {step}")
    if S.snap_distance is not None and S.points is None:
        print(f"snapped positions to vertices: largest distance {S.snap_distance.max():.3g}")
    elif S.snap_distance is not None:
        print(f"positions kept where they are (located on the surface); largest distance to a vertex "
              f"{S.snap_distance.max():.3g}")
    bar = StepBar(chunks, enabled=not args.quiet, desc="manifill reconstruct (time steps)")
    try:
        with dask_client(args.scheduler, check_workers(args), local=False,
                         what="--workers" if args.workers is not None else "--scheduler") as client:
            done = reconstruct_series(V, F, **where, path=out, times=series.times, name=series.names[0],
                                      chunk=step, progress=bar, check=True if args.check else None, client=client,
                                      **options)
    finally:
        bar.close()
    rep = done.report
    if rep.get("check"):
        bad = sum(not c["holds"] for c in rep["check"])
        which = "the last step" if done.linear_map else "the last chunk"
        print(f"step 1 ({which}): gradual variation fails at {bad} of its steps" if bad else
              f"step 1 ({which}): gradual variation holds")
    print(f"method: {rep['method']}" + (" (the default)" if rep.get("default") else "")
          + (f", solver={rep['fill'].get('solver')}" if "fill" in rep else "")
          + (f"; linear: {len(where['vals']):,} solves for its map, one product per chunk" if done.linear_map
             else ""))
    print_time(args, done.seconds)
    print(f"wrote {out} ({T:,} steps)")
    return 0
