"""Memory estimates, and the refusal of a problem that would not fit.

A solid at 256^3 voxels has 17 million unknowns; a solver that runs out of
memory is killed by the system with no message. Before the large steps,
manifill estimates what they will hold at their peak and compares it with the
memory this process can still get (:func:`available_bytes`: the system's
available memory, the limits of the process's cgroup and of every cgroup above
it, and its address-space limit); a problem predicted not to fit is refused
with the estimate and a way out, before anything is allocated.
"""

import math
import os

try:
    import resource
except ImportError:  # not on this platform
    resource = None  # type: ignore[assignment]

from .errors import ResourceError

__all__ = ["LIMIT_ENV", "available_bytes", "check_fits", "human", "lu_memory"]

#: Environment variable holding a memory limit in bytes for this process (a batch worker's), on top of the
#: system's own limits: :func:`available_bytes` counts it less the process's resident memory.
LIMIT_ENV = "MANIFILL_MEMORY_LIMIT"

#: Limits at or above this are "no limit" (cgroup v1 writes 2**63 rounded down to a page).
_UNLIMITED = 2**60


def _read(path):
    """The stripped text of a small file, or ``None`` if it cannot be read."""
    try:
        with open(path, errors="replace") as fh:
            return fh.read(1 << 20).strip()
    except (OSError, ValueError):
        return None


def _number(path):
    """A file holding one non-negative integer below :data:`_UNLIMITED` (``None`` for 'max', missing, other)."""
    text = _read(path)
    if text is None or not text.isdigit():
        return None
    value = int(text)
    return value if value < _UNLIMITED else None


def _stat(path, key):
    """The value of ``key`` in a ``memory.stat`` file (0 if absent)."""
    text = _read(path) or ""
    for line in text.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0] == key and parts[1].isdigit():
            return int(parts[1])
    return 0


def _status_kb(root, key):
    """A ``kB`` field of ``/proc/self/status`` (e.g. ``VmSize``) in bytes, or ``None``."""
    text = _read(os.path.join(root, "proc/self/status")) or ""
    for line in text.splitlines():
        if line.startswith(key + ":"):
            parts = line.split()
            if len(parts) >= 2 and parts[1].isdigit():
                return int(parts[1]) * 1024
    return None


def _meminfo(root):
    """``MemAvailable`` from ``/proc/meminfo`` in bytes, or ``None``."""
    text = _read(os.path.join(root, "proc/meminfo")) or ""
    for line in text.splitlines():
        if line.startswith("MemAvailable:"):
            parts = line.split()
            if len(parts) >= 2 and parts[1].isdigit():
                return int(parts[1]) * 1024
    return None


def _mounts(root):
    """Mount points of the cgroup v2 hierarchy and of the v1 ``memory`` controller, with the cgroup at each.

    Read from ``/proc/self/mountinfo``; the usual places (``/sys/fs/cgroup``,
    ``/sys/fs/cgroup/unified``, ``/sys/fs/cgroup/memory``, each mounting the
    root cgroup) when it says nothing.

    Returns
    -------
    v2, v1 : lists of (mount point, cgroup path mounted there)
    """
    v2, v1 = [], []
    for line in (_read(os.path.join(root, "proc/self/mountinfo")) or "").splitlines():
        left, sep, right = line.partition(" - ")
        fields, rest = left.split(), right.split()
        if not sep or len(fields) < 5 or len(rest) < 1:
            continue
        mounted, point = fields[3], fields[4].replace("\\040", " ")
        if rest[0] == "cgroup2":
            v2.append((point, mounted))
        elif rest[0] == "cgroup" and len(rest) >= 3 and "memory" in rest[2].split(","):
            v1.append((point, mounted))
    if not v2:
        v2 = [("/sys/fs/cgroup", "/"), ("/sys/fs/cgroup/unified", "/")]
    if not v1:
        v1 = [("/sys/fs/cgroup/memory", "/")]
    return v2, v1


def _own_cgroups(root):
    """This process's cgroup v2 path and v1 ``memory`` path from ``/proc/self/cgroup`` (``None`` when absent)."""
    v2 = v1 = None
    for line in (_read(os.path.join(root, "proc/self/cgroup")) or "").splitlines():
        ident, _, rest = line.partition(":")
        controllers, _, path = rest.partition(":")
        if not path.startswith("/"):
            continue
        if ident == "0" and controllers == "":
            v2 = path
        elif "memory" in controllers.split(","):
            v1 = path
    return v2, v1


def _chain(root, point, mounted, path):
    """Directories of ``path`` and of every cgroup above it, up to the top of the mount at ``point``."""
    rel = path
    if mounted not in ("", "/") and (path == mounted or path.startswith(mounted.rstrip("/") + "/")):
        rel = path[len(mounted.rstrip("/")):]  # the mount shows the cgroup tree from ``mounted`` down
    parts = [p for p in rel.split("/") if p and p not in (".", "..")]
    base = os.path.join(root, point.lstrip("/"))
    return [os.path.join(base, *parts[:k]) for k in range(len(parts), -1, -1)]


def _cgroup_room(root):
    """The least room left under the memory limits of this process's cgroups and their ancestors, or ``None``.

    The room under a limit is the limit less the memory charged to the group,
    not counting its inactive file cache, which the kernel reclaims before it
    refuses memory.
    """
    own_v2, own_v1 = _own_cgroups(root)
    mounts_v2, mounts_v1 = _mounts(root)
    rooms = []
    seen = set()
    for paths, mounts, limit_name, used_name, cache_key in (
            ([own_v2] if own_v2 else ["/"], mounts_v2, "memory.max", "memory.current", "inactive_file"),
            ([own_v1] if own_v1 else ["/"], mounts_v1, "memory.limit_in_bytes", "memory.usage_in_bytes",
             "total_inactive_file")):
        for point, mounted in mounts:
            for path in paths:
                for d in _chain(root, point, mounted, path):
                    if d in seen:
                        continue
                    seen.add(d)
                    limit = _number(os.path.join(d, limit_name))
                    if limit is None:
                        continue
                    used = _number(os.path.join(d, used_name)) or 0
                    used = max(used - _stat(os.path.join(d, "memory.stat"), cache_key), 0)
                    rooms.append(max(limit - used, 0))
    return min(rooms) if rooms else None


def _rlimit_room(root, getrlimit):
    """Room under the soft address-space and data limits (RLIMIT_AS, RLIMIT_DATA), or ``None`` if unlimited."""
    if resource is None:  # not on this platform
        return None
    getrlimit = resource.getrlimit if getrlimit is None else getrlimit
    rooms = []
    for name, status in (("RLIMIT_AS", "VmSize"), ("RLIMIT_DATA", "VmData")):
        which = getattr(resource, name, None)
        if which is None:
            continue
        try:
            soft = getrlimit(which)[0]
        except (OSError, ValueError):
            continue
        if soft is None or soft == resource.RLIM_INFINITY or soft < 0 or soft >= _UNLIMITED:
            continue
        used = _status_kb(root, status) or 0
        rooms.append(max(int(soft) - used, 0))
    return min(rooms) if rooms else None


def _available_bytes(root="/", getrlimit=None):
    """:func:`available_bytes` with the files read under ``root`` and the limits read by ``getrlimit``.

    Parameters
    ----------
    root : str, optional
        The directory that holds ``proc/`` and ``sys/`` (``/``; a fake tree in tests).
    getrlimit : callable, optional
        ``resource.getrlimit`` by default.

    Returns
    -------
    int or None
    """
    rooms = [_meminfo(root), _cgroup_room(root), _rlimit_room(root, getrlimit)]
    if rooms[0] is None and root == "/":
        try:
            rooms[0] = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            pass
    rooms = [r for r in rooms if r is not None]
    return int(min(rooms)) if rooms else None


def available_bytes():
    """Memory this process can still get, in bytes (``None`` if unknown).

    The least of, each where it exists and sets a limit:

    - ``MemAvailable`` from ``/proc/meminfo`` (Linux; free physical pages elsewhere);
    - for the cgroup of this process and every cgroup above it up to the root,
      its memory limit less what it holds (cgroup v2 ``memory.max`` and
      ``memory.current``, cgroup v1 ``memory.limit_in_bytes`` and
      ``memory.usage_in_bytes`` of the ``memory`` controller), not counting the
      inactive file cache the kernel gives back first;
    - the soft ``RLIMIT_AS`` less the virtual size ``VmSize`` (and
      ``RLIMIT_DATA`` less ``VmData``).

    - :data:`LIMIT_ENV`, when set, less what this process holds (``VmRSS``): the
      memory limit a batch gives each worker (:mod:`manifill.cluster`).

    Returns
    -------
    int or None

    Examples
    --------
    >>> avail = available_bytes()
    >>> avail is None or avail >= 0
    True
    """
    room = _available_bytes()
    limit = os.environ.get(LIMIT_ENV, "").strip()
    if limit.isdigit():
        left = max(int(limit) - (_status_kb("/", "VmRSS") or 0), 0)
        room = left if room is None else min(room, left)
    return room


def human(nbytes):
    """``nbytes`` as a short string: ``'2.8 GB'``.

    Examples
    --------
    >>> human(2.8e9), human(512e6), human(1500), human(4.6e12)
    ('2.8 GB', '512 MB', '2 kB', '4.6 TB')
    """
    if not math.isfinite(nbytes):
        return "inf B"
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= size:
            return f"{nbytes / size:.1f} {unit}" if unit in ("TB", "GB") else f"{nbytes / size:.0f} {unit}"
    return f"{int(nbytes)} B"


def lu_memory(n, nnz, dim=2):
    """Estimated memory of the sparse LU factorisation of ``solver='direct'`` (SuperLU), in bytes.

    The factors fill in far beyond the matrix. Measured with SuperLU's default
    ordering, ``nnz(L + U)`` grows like ``n`` on a curve, like ``n log n`` on a
    surface (``1.8 (nnz / n) n log2 n``; 1.4 is taken, so that a refusal is
    sure) and like ``n^1.5`` in a solid (about ``(nnz / n) n^1.5``, with 7
    entries per row on a voxel grid and 15 on tets), at about 12 bytes per
    stored entry.

    Parameters
    ----------
    n : int
        Unknowns.
    nnz : int
        Stored entries of the matrix.
    dim : {1, 2, 3}, optional
        Dimension of the mesh the matrix comes from.

    Returns
    -------
    float

    Examples
    --------
    >>> human(lu_memory(50_000, 350_000, dim=3))  # a voxel solid: 1.2 GB measured
    '1.0 GB'
    >>> human(lu_memory(160_000, 1_120_000, dim=2))  # a surface: 380 MB measured
    '370 MB'
    """
    n, nnz = float(n), float(nnz)
    if n <= 0:
        return 0.0
    per_row = nnz / n
    if dim == 1:
        fill = 1.5 * nnz
    elif dim == 2:
        fill = 1.4 * per_row * n * math.log2(max(n, 2.0))
    else:
        fill = per_row * n ** 1.5
    return 13.0 * fill + 16.0 * nnz


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
