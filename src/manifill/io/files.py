"""Files on disk: atomic writes, suffix checks, and one guard that turns a damaged file into one line.

Every reader of manifill runs its parser inside :func:`reading`, so that whatever a
truncated, mutated or lying file makes a third-party parser raise ends as a
:class:`~manifill.errors.ReadError` naming the file and the fix, and so that the
parsers' own warnings (meshio's overflow warning on every ASCII STL, nibabel's
notes) never reach the user. A small file whose header claims billions of items is
"damaged", never "out of memory": :func:`check_count` compares claimed counts with
the bytes the file has before anything is allocated.
"""

import errno
import io
import logging
import os
import re
import shutil
import signal
import traceback
import warnings
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np

from ..errors import ManifillError, ReadError, WriteError

__all__ = ["atomic_path", "remove_temporaries", "remove_active_temporaries", "ACTIVE", "suffix", "reading", "quiet",
           "check_count", "check_input_file", "no_triangles", "PointsOnly", "KILL_ONCE_ENV", "kill_once_for_tests"]

#: loggers of the parsers that print their notes through handlers of their own
_PARSER_LOGGERS = ("nibabel",)

def suffix(path, allowed, what):
    """The lower-case extension of ``path``, checked against ``allowed``.

    Parameters
    ----------
    path : str or Path
    allowed : sequence of str
        Extensions with their dot (``'.vtu'``).
    what : str
        ``'read'`` or ``'write'`` (chooses the error class and the message).

    Returns
    -------
    str

    Raises
    ------
    ReadError or WriteError
        An extension not in ``allowed``.
    """
    ext = Path(path).suffix.lower()
    if ext not in allowed:
        raise (WriteError if what.startswith("write") else ReadError)(
            f"{Path(path).name}: cannot {what} '{ext or '(no extension)'}' files; use one of {', '.join(allowed)}"
        )
    return ext


def is_number(text):
    """Whether ``text`` reads as a float (a CSV cell, a header's name).

    Examples
    --------
    >>> is_number(" 1e-3"), is_number("x")
    (True, False)
    """
    try:
        float(text)
    except ValueError:
        return False
    return True


def check_input_file(path):
    """Raise :class:`ReadError` unless ``path`` is an existing regular file."""
    path = Path(path)
    if not path.is_file():
        raise ReadError(f"{path}: no such file" if not path.exists() else f"{path}: not a file; pass a file")


#: First bytes of files people pick by mistake, and what they are.
FOREIGN = ((b"\x89PNG\r\n\x1a\n", "a PNG image"), (b"\xff\xd8\xff", "a JPEG image"), (b"%PDF-", "a PDF document"),
           (b"GIF8", "a GIF image"), (b"PK\x03\x04", "a ZIP archive"), (b"\x1f\x8b", "a gzip archive"))


def check_not_foreign(path, what, thing, *, archive=False, gzip=False):
    r"""Refuse a file whose first bytes say it is an image, a PDF or an archive, naming what it is, what was
    expected (``what``, e.g. ``"a PLY mesh"``) and the file to pass instead (``thing``, e.g. ``"mesh"``);
    ``archive``: a ZIP is expected (``.npz``); ``gzip``: a gzip is (``.mgz``).

    Examples
    --------
    >>> import os, tempfile
    >>> p = os.path.join(tempfile.mkdtemp(), "scalp.ply")
    >>> _ = open(p, "wb").write(b"\x89PNG\r\n\x1a\n....")
    >>> check_not_foreign(p, "a PLY mesh", "mesh")
    Traceback (most recent call last):
    ...
    manifill.errors.ReadError: scalp.ply is a PNG image, not a PLY mesh; pass the mesh file itself
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError:
        return
    for magic, kind in FOREIGN:
        if head.startswith(magic) and not (archive and magic == b"PK\x03\x04") and not (gzip and magic == b"\x1f\x8b"):
            raise ReadError(f"{Path(path).name} is {kind}, not {what}; pass the {thing} file itself")


@contextmanager
def reading(path, kind):
    """Run a parser on ``path``; any failure of a malformed file becomes one :class:`ReadError`.

    Parameters
    ----------
    path : str or Path
        The file being read (named in the message).
    kind : str
        What it should be (``'PLY mesh'``), for the message.

    Raises
    ------
    ReadError
        Instead of whatever the parser raised on a malformed file; manifill's
        own errors pass through unchanged.
    """
    name = Path(path).name
    try:
        with quiet():
            try:
                yield
            except Exception as exc:
                # a file the parser left open is closed here, its ResourceWarning ignored, not at a later collection
                traceback.clear_frames(exc.__traceback__)
                raise
    except ManifillError:
        raise
    except MemoryError:
        raise ReadError(f"{name}: not a readable {kind}: its header asks for more memory than there is, so the "
                        f"file is damaged; check or re-export it") from None
    except Exception as exc:  # noqa: BLE001 - the parsers raise anything (zipfile, struct, meshio, nibabel...)
        raise ReadError(f"{name}: not a readable {kind} ({_one_line(exc)}); check or re-export the file") from None


@contextmanager
def quiet():
    """Keep a third-party parser's or writer's notes from the user.

    Its warnings, what it prints itself (meshio writes notes to stderr) and the
    log lines of parsers with handlers of their own (nibabel) go nowhere.
    """
    with warnings.catch_warnings(), redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()), \
            _silent_loggers():
        warnings.simplefilter("ignore")
        yield


@contextmanager
def _silent_loggers():
    """Mute the loggers of parsers that print through handlers of their own (nibabel's header checks)."""
    loggers = [logging.getLogger(name) for name in _PARSER_LOGGERS]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


#: a parser's usual complaints, said in the terms of the file
_PLAIN = [
    (re.compile(r"could not convert string to float: (.*)"), r"\1 is not a number"),
    (re.compile(r"invalid literal for int\(\) with base \d+: (.*)"), r"\1 is not an integer"),
    (re.compile(r"string or file could not be read to its end due to unmatched data"),
     "text where numbers belong, or fewer numbers than its counts say"),
    (re.compile(r"cannot reshape array of size (\d+) into shape \(?(\d+), ?(\d+)\)?"),
     r"\1 numbers where its counts ask for \2 rows of \3"),
    (re.compile(r"cannot reshape array of size (\d+) into shape (\(.*\))"),
     r"\1 numbers where its header gives the shape \2"),
    (re.compile(r"'[\w-]+' codec can't decode bytes? (?:0x[0-9a-f]+ )?in position (\d+).*"),
     r"bytes that are not text at offset \1"),
    (re.compile(r"could not convert string (.*) to \w+ at row (\d+), column (\d+)\.?"),
     r"\1 (row \2, column \3) is not a number"),
    (re.compile(r"Some errors were detected ! Line #(\d+) \(got (\d+) columns instead of (\d+)\).*"),
     r"data line \1 holds \2 values where \3 belong"),
    (re.compile(r"buffer size must be a multiple of element size"), "binary data that ends inside a value"),
    (re.compile(r"too many values to unpack \(expected (\d+)\)"), r"a line with more than the \1 values expected"),
    (re.compile(r"list index out of range"), "a line with fewer items than it needs"),
    (re.compile(r"Python int(?:eger)? (-?\d+) out of bounds for (\w+)"),
     r"the value \1, which does not fit its type \2"),
    (re.compile(r"Python int too large to convert to C \w+"), "a number too large for its type"),
    (re.compile(r"setting an array element with a sequence.*"), "lines of different lengths where they should match"),
    (re.compile(r"no field of name (.*)"), r"no property named \1"),
    (re.compile(r"malformed node or string.*|\('EOF in multi-line statement'.*"),
     "a header that is not the dictionary an NPY array starts with"),
    (re.compile(r"\[Errno 22\] Invalid argument"), "a size or position in it that is impossible"),
]


def _one_line(exc):
    text = re.sub(r"<([\w.]+) object at 0x[0-9a-fA-F]+>", r"<\1>", " ".join(str(exc).split()))  # no addresses
    for pattern, plain in _PLAIN:
        if pattern.fullmatch(text):
            return pattern.sub(plain, text)[:200]
    if isinstance(exc, KeyError) and text:
        return f"the unknown name {text[:60]}"
    if type(exc).__name__ == "ReadError" and text:  # the parser's own words
        return text[:160]
    text = text[:160] + "..." if len(text) > 160 else text
    if text:
        return f"{type(exc).__name__}: {text}"
    return _SILENT.get(type(exc).__name__, f"{type(exc).__name__}, no reason given")


#: what a parser's exception without a message means
_SILENT = {"EOFError": "it ends early, truncated", "AssertionError": "a line its reader cannot parse",
           "ReadError": "its reader stopped at something it cannot parse, and gave no reason",
           "StopIteration": "it ends early, truncated"}


def check_count(count, path, what, *, bytes_each, start=0):
    """Refuse a header count that the rest of the file cannot hold.

    Parameters
    ----------
    count : int
        The count the header claims.
    path : str or Path
        The file.
    what : str
        What is counted (``'vertices'``).
    bytes_each : float
        The fewest bytes one item takes (e.g. 2 for an ASCII number and its
        separator, 24 for three binary doubles).
    start : int, optional
        Where the counted items begin in the file.

    Raises
    ------
    ReadError
        A negative count, or more items than the remaining bytes can hold.
    """
    size = os.path.getsize(path)
    if count < 0:
        raise ReadError(f"{Path(path).name}: the header claims {count} {what}; the file is damaged, check it")
    if count * bytes_each > size - start:
        raise ReadError(f"{Path(path).name}: the header claims {count:,} {what} but only {max(size - start, 0):,} "
                        f"bytes follow; the file is truncated or damaged, check it")


class PointsOnly(ReadError):
    """A mesh file that holds points and no triangles: a point cloud, for a caller that takes one.

    Attributes
    ----------
    V : (n, 3) numpy array or None
        The points read.
    point_data : dict
        The per-point fields read.
    """

    def __init__(self, message, V=None, point_data=None):
        super().__init__(message)
        self.V, self.point_data = V, dict(point_data or {})


def no_triangles(path, kinds, V=None, point_data=None):
    """Raise the ReadError of a mesh file that holds no triangles (a :class:`PointsOnly` carrying its points).

    Parameters
    ----------
    path : str or Path
        The file read.
    kinds : list of str
        The kinds of cells it holds (``'tetra'`` adds a hint to use ``manifill volume``).
    V : (n, 3) array_like, optional
        Its points, kept on the exception for a reader that takes point clouds.
    point_data : dict, optional
        Its per-point fields.

    Raises
    ------
    PointsOnly
        Always.
    """
    hint = "; for a solid of tetrahedra use 'manifill volume'" if "tetra" in kinds else ""
    n = 0 if V is None else len(V)
    cloud = f" ('manifill reconstruct' takes its {n:,} points as a point cloud)" if n and not hint else ""
    raise PointsOnly(f"{Path(path).name}: holds no triangles (cells found: {', '.join(kinds) or 'none'}){hint}; "
                     f"pass a surface mesh{cloud}", None if V is None else np.asarray(V, dtype=np.float64),
                     point_data)


def _space_cause(exc):
    """The cause of an OSError in a few words when it means the disk (or the quota) is full, else None (numpy's
    short write, "N requested and M written", has no errno)."""
    if exc.errno == errno.ENOSPC:
        return "no space left on the device"
    if exc.errno == errno.EDQUOT:
        return "disk quota exceeded"
    text = exc.strerror or str(exc)
    if exc.errno == errno.EFBIG:
        return text
    return f"{text}: the disk is probably full" if "requested" in text and "written" in text else None


def _remove(p):
    """Remove a file or a folder (not following a symlink to one); say nothing if it cannot."""
    try:
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
    except OSError:
        pass


def _alive(pid):
    """Whether process ``pid`` runs on this host (or cannot be told: then it counts as alive)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):
        return True
    return True


def remove_temporaries(output, *, dead_only=True):
    """Remove the hidden temporaries ``.<name>.<pid>.<tag><suffix>`` that interrupted writes of ``output`` left
    beside it (and, for a ``.pvd`` series, of its folder ``<stem>/``): with ``dead_only``, only those of processes
    no longer running here (a live writer's are left alone). Returns what was removed."""
    output = Path(output)
    from .formats import find_format

    folder = getattr(find_format("series", output, writing=True), "folder", False)
    names = [output.name] + ([output.stem] if folder else [])
    patterns = [re.compile(r"^\." + re.escape(name) + r"\.(\d+)\.\w+") for name in names]
    try:
        entries = list(output.parent.iterdir())
    except OSError:
        return []
    removed = []
    for p in entries:
        m = next((m for m in (pat.match(p.name) for pat in patterns) if m), None)
        if m is None or int(m.group(1)) == os.getpid() or (dead_only and _alive(int(m.group(1)))):
            continue
        _remove(p)
        removed.append(p)
    return removed


@contextmanager
def atomic_path(path):
    """A temporary path beside ``path`` that replaces it on success.

    Parameters
    ----------
    path : str or Path
        Final destination.

    Yields
    ------
    Path
        Where to write; renamed to ``path`` when the block completes, removed
        if it raises (an interruption included: the old file stays as it was).

    Raises
    ------
    WriteError
        If the destination folder does not exist.
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise WriteError(f"folder {path.parent} does not exist; create it first or choose another output path")
    remove_temporaries(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp{path.suffix}")
    ACTIVE.add(tmp)
    try:
        try:
            yield tmp
        except OSError as exc:  # a full disk or a quota: the file and the cause, in one line (others as they are)
            cause = _space_cause(exc)
            if cause is None:
                raise
            raise WriteError(f"{path.name}: could not be written ({cause}); free some space or write it "
                             f"elsewhere") from None
        kill_once_for_tests()
        try:
            os.replace(tmp, path)
        except OSError as exc:
            raise WriteError(f"{path.name}: could not replace the file ({exc.strerror or exc}); check the "
                             f"folder's permissions and free space") from None
    finally:
        ACTIVE.discard(tmp)
        if tmp.exists():
            tmp.unlink()


#: The temporaries of the writes under way (:func:`atomic_path`), for a process that must stop at once.
ACTIVE: set = set()


def remove_active_temporaries():
    """Remove the temporaries of the writes under way: what a process stopped by ``os._exit`` leaves behind."""
    for tmp in list(ACTIVE):
        _remove(tmp)


#: TEST ONLY. When this environment variable names a file that does not exist, :func:`atomic_path` creates
#: that file and kills its own process (SIGKILL) after the temporary output is written and before it is renamed:
#: how the batch tests (:mod:`manifill.cluster`) kill a worker in the middle of a job, once.
KILL_ONCE_ENV = "MANIFILL_TEST_KILL_ONCE"


def kill_once_for_tests():
    """Kill this process if :data:`KILL_ONCE_ENV` names a marker file not yet there (creating it first)."""
    marker = os.environ.get(KILL_ONCE_ENV)
    if not marker or os.path.exists(marker):
        return
    with open(marker, "w") as fh:
        fh.write(f"killed process {os.getpid()}\n")
    os.kill(os.getpid(), signal.SIGKILL)
