"""The one thread policy of the solvers.

Two solvers run threads: the surface AMG deals independent blocks of a system
to threads (:class:`manifill.linalg.backends.AMGSolver`), and the voxel
multigrid runs its stencil passes on contiguous ranges of the grid, one per
thread (:class:`manifill.linalg.gridmg.GridMultigrid`). Both ask
:func:`workers` how many: the CPUs this process may run on (its affinity
mask, which a container or ``taskset`` may narrow, not the machine's count),
at most :data:`MAX_THREADS`. SciPy's sparse kernels and NumPy's vector
operations release the GIL, so threads share one copy of the data; beyond
four they gained nothing measurable, as the memory bandwidth is shared.

Results can differ in the last bits with the number of threads (sums split
into per-thread parts, blocks dealt to threads), never by more than the
solver's tolerance.
"""

import os

__all__ = ["MAX_THREADS", "cpus", "workers"]

#: Most threads any solver runs.
MAX_THREADS = 4


def cpus():
    """CPUs this process may run on (its affinity mask where the system has one).

    Examples
    --------
    >>> cpus() >= 1
    True
    """
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def workers(limit=None):
    """Threads a solver should run: :func:`cpus`, at most ``limit`` (default :data:`MAX_THREADS`).

    Parameters
    ----------
    limit : int, optional
        A smaller cap of the caller.

    Returns
    -------
    int
        At least 1.

    Examples
    --------
    >>> 1 <= workers() <= MAX_THREADS
    True
    """
    cap = MAX_THREADS if limit is None else min(int(limit), MAX_THREADS)
    return max(1, min(cpus(), cap))
