"""Chunks of work on the workers of a Dask cluster, handed back in order: one shared object, sent once.

:func:`ordered_map` is what :func:`manifill.io.stream.reconstruct_series` runs with a
``distributed.Client``: the shared object (a pickled :class:`manifill.Reconstructor`, whose
factorisation each worker builds again at its first chunk) goes once to every worker
(``Client.scatter(..., broadcast=True)``), each chunk is one task (``Client.submit``,
``pure=False``), and the results come back in the order of the chunks, however they finish
(a reorder buffer), with at most :data:`IN_FLIGHT` chunks per worker submitted and not yet
handed back, so that memory is bounded whatever the number of chunks. A chunk that raises
cancels the rest and raises its error in the caller.

``dask`` and ``distributed`` are the optional ``[batch]`` extra; nothing here imports them at
module level (:func:`need_distributed`).
"""

import contextlib
import logging
import os
import sys
import threading
import time

from ..errors import OptionError
from ..memory import human

#: The warning filter handed to multiprocessing's resource tracker (see :func:`local_cluster`).
QUIET_TRACKER = "ignore:resource_tracker:UserWarning"

__all__ = ["IN_FLIGHT", "EXTRA", "SCHEDULER_ENV", "need_distributed", "memory_bytes", "local_cluster", "dask_client",
           "ordered_map", "one_at_a_time"]

#: Dask's own variable naming the scheduler of an existing cluster.
SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"

#: Chunks per worker submitted and not yet handed back (computing, queued or waiting for an earlier one).
IN_FLIGHT = 2

#: What installs dask and distributed.
EXTRA = "pip install 'manifill[batch]'"

#: One chunk at a time in a worker process: a factorisation is not shared by concurrent solves.
_APPLY = threading.Lock()


def need_distributed(what="this"):
    """``distributed``, imported; manifill's own one-line error naming the ``[batch]`` extra when it is missing.

    Raises
    ------
    OptionError
        ``dask.distributed`` is not installed.
    """
    try:
        import distributed
    except ImportError:
        raise OptionError(f"{what} needs dask and distributed (the [batch] extra): {EXTRA}") from None
    return distributed


def memory_bytes(limit):
    """A worker's memory limit in bytes: ``None`` or ``'auto'`` give None (Dask's share of the machine), a number
    of bytes or a size (``'4GB'``, ``'512 MiB'``) its bytes.

    Raises
    ------
    OptionError
        Not a size, not above zero, above the machine's memory; dask/distributed missing (the ``[batch]`` extra).

    Examples
    --------
    >>> memory_bytes("4GB"), memory_bytes(1024), memory_bytes("auto")
    (4000000000, 1024, None)
    """
    if limit is None or (isinstance(limit, str) and limit.strip().lower() == "auto"):
        return None
    fix = "pass bytes or a size such as 4GB or 512MiB (CLI: --memory-limit 4GB)"
    if isinstance(limit, bool) or not isinstance(limit, (int, float, str)):
        raise OptionError(f"memory_limit={limit!r} is not a size; {fix}")
    need_distributed("a memory limit for Dask's workers")  # the [batch] extra named, not an ImportError
    if isinstance(limit, str):
        from dask.utils import parse_bytes

        try:
            value = parse_bytes(limit.strip())
        except (ValueError, TypeError):
            raise OptionError(f"memory_limit={limit!r} is not a size; {fix}") from None
    else:
        value = limit
    if not (value >= 1 and value < 2**63):
        raise OptionError(f"memory_limit={limit!r} is not a size above zero; {fix}")
    from distributed.system import MEMORY_LIMIT  # what Dask allows a worker: the machine's, or its cgroup's

    if value > MEMORY_LIMIT:
        raise OptionError(f"memory_limit={limit!r} is more than this machine's {human(MEMORY_LIMIT)} of memory; pass "
                          f"at most that per worker (CLI: --memory-limit), or leave it out (the machine's shared "
                          f"among the workers)")
    return int(value)


def local_cluster(workers, memory_limit="auto", what="this"):
    """A ``distributed.LocalCluster`` of ``workers`` processes, one thread each, for manifill's work.

    As Dask's own but for one setting: Dask starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536``
    (``distributed.nanny.pre-spawn-environ``), which fixes glibc's thresholds so that every array
    above 128 KiB is mapped and unmapped afresh; manifill's jobs, which allocate and free many
    arrays of megabytes, ran 1.5x slower so (measured: 10.5 s against 6.8 s for eight 40k-160k
    jobs in one process). The workers here keep glibc's adaptive default. No dashboard port is
    claimed (``:0``: any free one).

    Raises
    ------
    OptionError
        ``dask.distributed`` is not installed (the ``[batch]`` extra).
    """
    distributed = need_distributed(what)
    import dask

    env = {k: v for k, v in (dask.config.get("distributed.nanny.pre-spawn-environ", default={}) or {}).items()
           if k != "MALLOC_TRIM_THRESHOLD_"}
    # a worker killed mid-job (and restarted by its nanny) leaves a semaphore that multiprocessing's resource
    # tracker removes at shutdown, with a two-line warning that says nothing to the user: the tracker (started
    # with this interpreter's -W options) is told to keep quiet about it
    if QUIET_TRACKER not in sys.warnoptions:
        sys.warnoptions.append(QUIET_TRACKER)
    # a worker over its limit's pause fraction stops taking tasks until its memory falls, which a process that
    # holds its own heap never does: the batch would wait for ever. Without the pause a worker over its limit is
    # restarted by its nanny instead, and manifill's own estimates refuse what will not fit before it runs
    with dask.config.set({"distributed.nanny.pre-spawn-environ": env, "distributed.worker.memory.pause": False}):
        # the workers' logs stay quiet but for the critical: a worker closing with its cluster logged a connection's
        # traceback on the user's terminal (a job's own failure is its summary row)
        return distributed.LocalCluster(n_workers=int(workers), threads_per_worker=1, processes=True,
                                        memory_limit=memory_limit, dashboard_address=":0",
                                        silence_logs=logging.CRITICAL)


@contextlib.contextmanager
def dask_client(scheduler=None, workers=None, memory_limit=None, *, local=True, what="this"):
    """A ``distributed.Client`` for manifill's work, closed at the end (a cluster it started, too).

    Parameters
    ----------
    scheduler : str or distributed.Client, optional
        An existing cluster: its scheduler's address, or a client of it (used as it is, not
        closed). Default: :data:`SCHEDULER_ENV` when set and neither ``workers`` nor
        ``memory_limit`` asks for a local cluster.
    workers : int, optional
        Processes of a :func:`local_cluster` (default: one per core).
    memory_limit : str or int, optional
        Memory of each local worker (default: ``'auto'``, the machine's shared among them).
    local : bool, optional
        Without a scheduler and ``workers``: a local cluster (True) or no client, None (False).
    what : str, optional
        What needs the cluster, for the error naming the ``[batch]`` extra.

    Raises
    ------
    OptionError
        dask/distributed missing; a scheduler address with ``workers`` or ``memory_limit``; no
        scheduler answering at the address; ``workers`` not a whole number >= 1.
    """
    if scheduler is not None and not isinstance(scheduler, str):
        yield scheduler
        return
    address = scheduler or (os.environ.get(SCHEDULER_ENV) if workers is None and memory_limit is None else None)
    if not address and workers is None and not local:
        yield None
        return
    distributed = need_distributed(what)
    if address:
        if workers is not None or memory_limit is not None:
            raise OptionError("workers and memory_limit shape a local cluster; leave them out with a scheduler "
                              "address (that cluster sets its own)")
        try:
            client = distributed.Client(address, timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise OptionError(f"no Dask scheduler answers at {address} ({' '.join(str(exc).split())}); start one "
                              f"('dask scheduler') or leave the address out") from None
        with client:
            yield client
        return
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise OptionError(f"workers={workers!r} is not a whole number >= 1; pass one (default: one per core)")
    limit = memory_bytes(memory_limit)
    cluster = local_cluster(workers or os.cpu_count() or 1, "auto" if limit is None else limit, what)
    with cluster, distributed.Client(cluster) as client:
        yield client


def one_at_a_time(fn, *args):
    """``fn(*args)`` under this process's lock (workers with several threads run one chunk at a time).

    Examples
    --------
    >>> one_at_a_time(max, 2, 3)
    3
    """
    with _APPLY:
        return fn(*args)


def ordered_map(client, fn, shared, args, *, in_flight=IN_FLIGHT, seconds=None):
    """``fn(shared, *a)`` for each tuple ``a`` of ``args``, on the client's workers; yielded in the order of ``args``.

    Parameters
    ----------
    client : distributed.Client
        The cluster's client (the caller's: it is not closed here).
    fn : callable
        A module-level function (workers import it by name); run under :func:`one_at_a_time`.
    shared : object
        Sent once to every worker (picklable).
    args : iterable of tuple
        One per task, read as tasks are submitted.
    in_flight : int, optional
        Tasks per worker submitted and not yet yielded (at least 1).
    seconds : dict, optional
        Gets ``send`` (the broadcast) and ``wait`` (time blocked on results) added.

    Yields
    ------
    object
        ``fn(shared, *a)``, in order.

    Raises
    ------
    Exception
        The first error of a task (its own type and message); the tasks not finished are cancelled.
    """
    distributed = need_distributed("a series on a Dask cluster")
    seconds = {} if seconds is None else seconds
    t = time.perf_counter()
    remote = client.scatter(shared, broadcast=True, hash=False)
    seconds["send"] = seconds.get("send", 0.0) + time.perf_counter() - t
    limit = max(1, int(in_flight)) * max(1, len(client.nthreads()))
    tasks = enumerate(args)
    pending, ready, nxt = {}, {}, 0  # future -> position; position -> result; next position to yield
    finished = distributed.as_completed()

    def submit():
        for i, a in tasks:
            f = client.submit(one_at_a_time, fn, remote, *a, pure=False)
            pending[f] = i
            finished.add(f)
            return True
        return False

    try:
        while len(pending) + len(ready) < limit and submit():
            pass
        while pending:
            t = time.perf_counter()
            f = next(finished)
            i = pending.pop(f)
            ready[i] = f.result()  # a task's error is raised here, as itself
            seconds["wait"] = seconds.get("wait", 0.0) + time.perf_counter() - t
            f.release()
            while nxt in ready:
                yield ready.pop(nxt)
                nxt += 1
                while len(pending) + len(ready) < limit and submit():
                    pass
    finally:
        if pending:
            client.cancel(list(pending))
        remote.release()
