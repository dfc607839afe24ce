"""Memory estimates, and the refusal of a problem that would not fit.

A solid at 256^3 voxels has 17 million unknowns; a solver that runs out of
memory is killed by the system with no message. Before the large steps,
manifill estimates what they will hold at their peak and compares it with the
memory the system reports as available; a problem predicted not to fit is
refused with the estimate and a way out, before anything is allocated.
"""

import os

from .errors import ResourceError

__all__ = ["available_bytes", "check_fits", "human"]


def available_bytes():
    """Memory the system can give this process now, in bytes (``None`` if unknown).

    ``MemAvailable`` from ``/proc/meminfo`` where it exists (Linux), else free
    physical pages; capped by a cgroup memory limit when one is set.
    """
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except OSError:
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            avail = None
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path) as fh:
                text = fh.read().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 2**60:
            limit = int(text)
            used = path.replace("memory.max", "memory.current").replace("limit_in_bytes", "usage_in_bytes")
            try:
                with open(used) as fh:
                    limit -= int(fh.read().strip())
            except (OSError, ValueError):
                pass
            avail = limit if avail is None else min(avail, limit)
    return avail


def human(nbytes):
    """``nbytes`` as a short string: ``'2.8 GB'``.

    Examples
    --------
    >>> human(2.8e9), human(512e6), human(1500)
    ('2.8 GB', '512 MB', '2 kB')
    """
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= size:
            return f"{nbytes / size:.1f} {unit}" if unit == "GB" else f"{nbytes / size:.0f} {unit}"
    return f"{int(nbytes)} B"


def check_fits(nbytes, what, fix, *, available=None):
    """Raise :class:`~manifill.errors.ResourceError` if ``nbytes`` will not fit.

    Parameters
    ----------
    nbytes : float
        The estimated peak.
    what : str
        What needs it, for the message (e.g. ``"the harmonic fill of 17,000,000 voxels"``).
    fix : str
        How to make it smaller (e.g. ``"lower --resolution"``).
    available : int, optional
        Bytes available; by default :func:`available_bytes`. Unknown: no check.

    Examples
    --------
    >>> check_fits(1e9, "a fill", "lower the resolution", available=2e9)
    >>> check_fits(3e9, "a fill", "lower the resolution", available=2e9)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    manifill.errors.ResourceError: a fill needs about 3.0 GB but only 2.0 GB of memory is available; lower ...
    """
    available = available_bytes() if available is None else available
    if available is not None and nbytes > available:
        raise ResourceError(f"{what} needs about {human(nbytes)} but only {human(available)} of memory is "
                            f"available; {fix}")
