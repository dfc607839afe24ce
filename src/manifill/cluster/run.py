"""Running a batch: every job to a Dask worker, one summary row each, finished jobs skipped on a re-run.

:func:`batch` reads the jobs (:mod:`manifill.cluster.manifest`), leaves out those a previous
run finished with the same inputs, options and outputs (the job's hash, recorded in the
summary), and submits the others to ``dask.distributed``. On the worker, :func:`run_job`
removes what an earlier, killed attempt left (hidden temporary files beside the outputs),
estimates the job's memory against the worker's limit and refuses it with the estimate if
it will not fit, then runs the job's command line in-process (:func:`manifill.cli.main.main`,
output captured) with the worker's limit passed on to manifill's own checks
(:data:`manifill.memory.LIMIT_ENV`). A job that fails gives its one-line error to its row
and never stops the others; a worker that dies is restarted by its nanny and the job
retried by the scheduler (``distributed.scheduler.allowed-failures`` times, 3 by default).
The summary CSV is rewritten, atomically, as jobs end (at most once a second, and after the
last): a batch stopped midway keeps the rows of the jobs that ended before its last write.
"""

from __future__ import annotations

import contextlib
import csv
import io
import os
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..cli.main import main
from ..errors import ManifillError, OptionError
from ..io import read_mesh_file
from ..io.distributed import SCHEDULER_ENV, dask_client, memory_bytes
from ..io.distributed import need_distributed as need
from ..io.files import KILL_ONCE_ENV, atomic_path, remove_temporaries
from ..io.registry import reading_once
from ..io.samples import read_sample_table
from ..io.formats import find_format
from ..io.series import series_only
from ..io.stream import chunk_size
from ..memory import LIMIT_ENV, human
from .hashing import job_hash
from .manifest import Job, jobs_from

if TYPE_CHECKING:  # the [batch] extra's client, a type here only
    import distributed

__all__ = ["batch", "BatchResult", "need_distributed", "run_job", "job_memory", "read_summary",
           "SUMMARY_COLUMNS", "SCHEDULER_ENV", "SUMMARY_SECONDS", "BYTES_PER_VERTEX", "BYTES_PER_VALUE", "WORKER_BYTES"]

#: The summary's columns, one row per job in the manifest's order.
SUMMARY_COLUMNS = ("id", "command", "status", "seconds", "peak_mb", "worker", "output", "hash", "error")
#: A surface job's memory per vertex, apart from its fields (measured: 891 bytes at 2.6M vertices, one field).
BYTES_PER_VERTEX = 1000
#: ... and per vertex and field: the values and the solver's copies of them, four float64.
BYTES_PER_VALUE = 32
#: A local worker's own memory before and between jobs: the interpreter, Dask, NumPy, SciPy and manifill (measured:
#: 120 MB idle, up to 190 MB after small jobs). A memory limit below it and a job's estimate refuses the job.
WORKER_BYTES = 200 * 2**20
_SAMPLE_SECONDS = 0.02
#: The summary is rewritten at most this often while jobs end (and always after the last one).
SUMMARY_SECONDS = 1.0


def need_distributed():
    """``distributed``, imported; manifill's own error naming the ``[batch]`` extra when it is missing.

    Raises
    ------
    OptionError
        ``dask.distributed`` is not installed.
    """
    return need("a batch on a Dask cluster")


@dataclass
class BatchResult:
    """What :func:`batch` did.

    Attributes
    ----------
    rows : list of dict
        One per job, in the manifest's order, with the keys :data:`SUMMARY_COLUMNS`;
        ``status`` is ``done``, ``skipped`` (finished before, unchanged), ``failed`` or
        ``refused`` (would not fit in a worker's memory).
    summary : Path
        The summary CSV.
    seconds : float
        Wall time of the batch.
    workers : int
        Workers of the cluster when the batch started.
    """

    rows: list
    summary: Path
    seconds: float
    workers: int

    @property
    def ok(self) -> bool:
        """Whether every job is ``done`` or ``skipped``."""
        return all(r["status"] in ("done", "skipped") for r in self.rows)

    def counts(self) -> dict[str, int]:
        """Jobs by status, e.g. ``{'done': 38, 'failed': 1, 'skipped': 1}``."""
        out: dict[str, int] = {}
        for r in self.rows:
            out[r["status"]] = out.get(r["status"], 0) + 1
        return out


def batch(jobs: str | os.PathLike[str] | Sequence[Mapping[str, Any] | Job], *,
          scheduler: str | distributed.Client | None = None, workers: int | None = None,
          memory_limit: str | int | None = None, summary: str | os.PathLike[str] | None = None, force: bool = False,
          progress: Callable[[dict[str, Any], int, int], object] | None = None) -> BatchResult:
    """Run a batch of ``manifill reconstruct`` / ``manifill volume`` jobs on a Dask cluster.

    Parameters
    ----------
    jobs : str, Path or list
        A manifest (``.csv`` or ``.toml``, :func:`manifill.cluster.manifest.read_manifest`),
        or a list of job dicts (the keys of a TOML ``[[job]]``) or ``Job`` objects.
    scheduler : str or distributed.Client, optional
        An existing cluster: its scheduler's address (``tcp://host:8786``) or a client of it.
        Default: the ``DASK_SCHEDULER_ADDRESS`` environment variable when set, else a
        ``LocalCluster`` on this machine, closed at the end.
    workers : int, optional
        Worker processes of the local cluster, one thread each (default: one per core).
    memory_limit : str or int, optional
        Memory of each local worker (``'4GB'``, bytes; default: the machine's memory shared
        among the workers). Jobs estimated above what their worker has are refused.
    summary : str or Path, optional
        The summary CSV. Default: ``<manifest>.summary.csv`` beside a manifest, else
        ``batch-summary.csv`` in the current folder. A previous summary there tells which jobs
        are finished.
    force : bool, optional
        Run every job again, finished or not.
    progress : callable, optional
        Called as ``progress(row, finished, total)`` as each job ends (skipped ones included).

    Returns
    -------
    BatchResult

    Raises
    ------
    OptionError
        dask/distributed missing (the ``[batch]`` extra), no scheduler at the address,
        local-cluster options given with an existing cluster; a bad manifest (as
        :func:`~manifill.cluster.manifest.read_manifest`).
    """
    t0 = time.perf_counter()
    limit = memory_bytes(memory_limit)  # a size that is not one: refused before anything runs
    job_list = jobs_from(jobs)
    path = _summary_path(jobs, summary)
    if any(path.resolve() == Path(o).resolve() for j in job_list for o in j.outputs()):
        raise OptionError(f"the summary {path} is also a job's output; pass another summary path")
    if any(path.resolve() == Path(p).resolve() for j in job_list for p in (j.mesh, j.samples)):
        raise OptionError(f"the summary {path} is also a job's input; pass another summary path")
    earlier = read_summary(path)  # kept for the jobs this run has not finished (--force, a signal)
    previous = {} if force else earlier
    rows, todo = {}, []
    for job in job_list:
        try:
            digest = job_hash(job)
        except (ManifillError, OSError) as exc:  # an input that cannot be read: this job's failure alone
            rows[job.id] = _row(job, "", status="failed", error=_one_line(exc))
            continue
        old = previous.get(job.id)
        if old and old.get("status") in ("done", "skipped") and old.get("hash") == digest and _outputs_exist(job):
            rows[job.id] = dict(old, status="skipped")
            continue
        try:  # the outputs' folders, made here (a manifest that writes to out/ works as written)
            for out in job.outputs():
                Path(out).parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            rows[job.id] = _row(job, digest, status="failed",
                                error=f"could not make the folder of {Path(out).name} ({exc.strerror or exc})")
            continue
        refusal = _refusal(job, limit) if limit is not None and scheduler is None else None
        if refusal:  # too big for every worker of the local cluster: refused now, with its estimate
            rows[job.id] = _row(job, digest, status="refused", error=refusal)
            continue
        todo.append((job, digest))
    finished, written = 0, -1.0

    def record(job, row):
        nonlocal finished, written
        rows[job.id] = row
        finished += 1
        now = time.perf_counter()
        if finished == len(job_list) or now - written >= SUMMARY_SECONDS:  # O(jobs) per write: not every job
            write_summary(path, _known(job_list, rows, earlier))
            written = now
        if progress is not None:
            progress(row, finished, len(job_list))

    for job in job_list:
        if job.id in rows:
            record(job, rows[job.id])
    count = 0
    if todo:
        distributed = need_distributed()
        with dask_client(scheduler, workers, memory_limit, what="a batch on a Dask cluster") as client:
            count = len(client.scheduler_info().get("workers", {}))
            futures = {client.submit(run_job, job, digest, key=f"manifill-job-{job.id}-{digest[:12]}", pure=False,
                                     priority=_size(job)): (job, digest) for job, digest in todo}
            try:
                for future in distributed.as_completed(futures):
                    job, digest = futures[future]
                    try:
                        row = future.result()
                    except distributed.KilledWorker:
                        row = _row(job, digest, status="failed",
                                   error="its worker died every time it ran it (out of memory, or killed); give "
                                         "workers more memory (--memory-limit) or run the job alone")
                    except Exception as exc:  # noqa: BLE001 - the cluster's failure, reported for this job alone
                        row = _row(job, digest, status="failed", error=f"{type(exc).__name__}: {_one_line(exc)}")
                    record(job, row)
            finally:  # interrupted (SIGTERM, Ctrl-C): the jobs that finished are in the summary, not recomputed
                _collect(distributed, futures, rows)
                write_summary(path, _known(job_list, rows, earlier))
    return BatchResult(rows=[rows[j.id] for j in job_list], summary=path, seconds=time.perf_counter() - t0,
                       workers=count)


#: Seconds an interrupted batch waits for the results of jobs whose outputs may be written already.
LAST_RESULTS_SECONDS = 1.0


def _collect(distributed, futures, rows):
    """The rows of jobs finished by now, waiting a moment for results on their way from the workers."""
    pending = [f for f, (job, _) in futures.items() if job.id not in rows and f.status != "finished"]
    if pending:
        try:
            distributed.wait(pending, timeout=LAST_RESULTS_SECONDS)
        except Exception:  # noqa: BLE001 - a timeout or a client closing: what has arrived is kept
            pass
    for future, (job, _digest) in futures.items():
        if job.id not in rows and future.status == "finished":
            try:
                rows[job.id] = future.result(timeout=LAST_RESULTS_SECONDS)
            except Exception:  # noqa: BLE001 - lost with the cluster: the job runs again next time
                pass


def _refusal(job, limit):
    """Why a job will not fit in a local worker of ``limit`` bytes (its estimate and a worker's own memory), or
    None. A job whose inputs cannot be read is left to fail with its own message when it runs, unless no worker
    can run with the limit at all."""
    try:
        need = job_memory(job)
    except ManifillError:
        need = None  # its own error when it runs, if a worker can run at all
    total = WORKER_BYTES + (need or 0)
    if total <= limit:
        return None
    parts = f"a worker's own {human(WORKER_BYTES)}" + (f" and the job's {human(need)}" if need else "")
    return (f"needs about {human(total)} ({parts}) but each worker has {human(limit)}; give workers more memory "
            f"(--memory-limit) or run fewer per machine")


def _known(job_list, rows, earlier):
    """The summary's rows: this run's, and an earlier run's for jobs this one has not finished."""
    return [rows.get(j.id) or earlier[j.id] for j in job_list if j.id in rows or j.id in earlier]


def _size(job):
    """The job's mesh file size in bytes: Dask starts larger jobs first, so that no worker is left with a big one
    at the end while the others wait."""
    try:
        return Path(job.mesh).stat().st_size
    except OSError:
        return 0


def _summary_path(jobs, summary):
    if summary is not None:
        return Path(summary)
    if isinstance(jobs, (str, os.PathLike)):
        p = Path(jobs)
        return p.with_name(p.stem + ".summary.csv")
    return Path("batch-summary.csv")


def _row(job, digest, **values):
    row = dict.fromkeys(SUMMARY_COLUMNS, "")
    row.update(id=job.id, command=job.command, output=str(job.output), hash=digest)
    row.update(values)
    return row


def _one_line(exc):
    text = " ".join(str(exc).split())
    return text[:300] if text else type(exc).__name__


def _outputs_exist(job):
    return all(Path(p).exists() for p in job.outputs())


def read_summary(path):
    """The rows of a summary CSV by job id (``{}`` when there is none, or it cannot be read)."""
    path = Path(path)
    if not path.is_file():
        return {}
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            return {r["id"]: r for r in csv.DictReader(fh) if r.get("id")}
    except (OSError, csv.Error, UnicodeDecodeError, KeyError):
        return {}


def write_summary(path, rows):
    """Write the summary CSV atomically (a reader never sees half of it)."""
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=SUMMARY_COLUMNS, extrasaction="ignore")
            w.writeheader()
            for r in rows:
                w.writerow(r)


def job_memory(job):
    """Estimated peak memory of a ``reconstruct`` job in bytes (``None`` for a ``volume`` job).

    ``n (BYTES_PER_VERTEX + BYTES_PER_VALUE p)`` for ``n`` vertices and ``p`` fields (of a time
    series written chunk by chunk: one chunk's fields). A volume job's own estimates
    (:func:`manifill.solid.estimates.reconstruct_volume_memory` and the fills') run inside it,
    against the same worker limit.

    Raises
    ------
    ManifillError
        The mesh or the samples cannot be read (the job's failure, with that message).
    """
    if job.command != "reconstruct":
        return None
    n = len(read_mesh_file(job.mesh).V)
    samples = Path(job.samples)
    p = 1
    fmt = find_format("samples", samples)
    if samples.is_file() and fmt is not None and fmt.extra is None:  # a table read without any extra
        tab = read_sample_table(samples, n)
        p = max(1, tab.table.shape[1] - (1 if tab.kind == "vertex" else 3))
    if series_only(job.output):
        p = min(p, chunk_size(n, p))
    return n * (BYTES_PER_VERTEX + BYTES_PER_VALUE * p)


def _worker():
    """``(address, memory limit in bytes or None)`` of the Dask worker running this, or ``('', None)``."""
    try:
        from distributed import get_worker

        w = get_worker()
    except (ImportError, ValueError):
        return "", None
    limit = getattr(getattr(w, "memory_manager", None), "memory_limit", None) or getattr(w, "memory_limit", None)
    return str(w.address), (int(limit) if limit else None)


def _rss():
    import psutil

    return psutil.Process().memory_info().rss


class _Peak:
    """The largest resident memory of this process while the block runs (sampled every 20 ms)."""

    def __enter__(self):
        self.peak, self._stop = _rss(), threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()
        return self

    def _watch(self):
        while not self._stop.wait(_SAMPLE_SECONDS):
            self.peak = max(self.peak, _rss())

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, _rss())


@contextlib.contextmanager
def _environ(values):
    before = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in before.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def run_job(job, digest):
    """Run one job where this is called (a Dask worker): its summary row.

    Never raises for the job's own failures: they are the row's ``status`` and ``error``.
    """
    with reading_once():  # the mesh is parsed once, for the estimate and the command line
        return _run_job(job, digest)


def _run_job(job, digest):
    t0 = time.perf_counter()
    address, limit = _worker()
    for out in job.outputs():
        remove_temporaries(out, dead_only=False)  # this job is the output's only writer
    try:
        need = job_memory(job)
    except ManifillError as exc:
        return _row(job, digest, status="failed", worker=address, error=_one_line(exc))
    held = _rss()
    if limit and need is not None and need > limit - held:
        return _row(job, digest, status="refused", worker=address,
                    error=f"needs about {human(need)} but its worker has {human(max(limit - held, 0))} of its "
                          f"{human(limit)}; give workers more memory (--memory-limit) or run fewer per machine")
    argv = [str(a) for a in job.argv()]
    if not {"-q", "--quiet", "-v", "--verbose"} & set(argv):
        argv.append("--quiet")
    env = {LIMIT_ENV: str(limit)} if limit else {}
    if job.kill_once:
        env[KILL_ONCE_ENV] = str(job.kill_once)
    out, err = io.StringIO(), io.StringIO()
    with _environ(env), _Peak() as peak, contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    row = _row(job, digest, worker=address, seconds=f"{time.perf_counter() - t0:.3f}",
               peak_mb=f"{peak.peak / 2**20:.0f}")
    if code != 0:
        lines = [ln for ln in err.getvalue().splitlines() if ln.startswith("manifill:")] or \
            err.getvalue().strip().splitlines()[-1:] or [f"exit code {code}"]
        text = lines[-1].removeprefix("manifill: error: ").removeprefix("manifill: ")
        refused = "of memory is available" in text
        row.update(status="refused" if refused else "failed", error=text)
        return row
    missing = [str(p) for p in job.outputs() if not Path(p).exists()]
    if missing:
        row.update(status="failed", error=f"the command ended well but did not write {', '.join(missing)}")
    else:
        row.update(status="done")
    return row
