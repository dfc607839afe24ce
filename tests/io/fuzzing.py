"""The fuzzing's shared parts: seed files, the damage strategies, and one command-line run judged.

:mod:`test_fuzz` (every reader, the older commands) and :mod:`test_fuzz_new_inputs` (the globe, batches, series,
clouds at extreme scales) draw damaged inputs with :func:`damage` and judge a run of ``manifill`` with
:func:`run_command`: exit 0 or 2 (1 only for ``check``'s failing condition), exactly one ``manifill: error:`` line
for 2, no traceback, warning, log record, slow run or huge allocation, and no file but complete outputs.
"""

import base64
import binascii
import logging
import re
import struct
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field

from hypothesis import strategies as st

from manifill.errors import ManifillError

SLOW = 5.0  # seconds: a run slower than this on inputs of a few kB counts as a hang

@dataclass
class Seed:
    """One valid file: its name, bytes, the reader that takes it, and which damage applies."""

    label: str
    name: str
    data: bytes
    reader: str
    text: bool = False  # a text format: lines can be duplicated or deleted
    runs: list = field(default_factory=list)  # (start, end) of base64 runs that decode
    zip: bool = False




def base64_runs(data):
    """(start, end) of every stretch of valid base64 in the text of an XML element (headers and blocks apart)."""
    if not data.startswith(b"<"):
        return []
    runs = []
    for m in re.finditer(rb">\s*([A-Za-z0-9+/=]{8,})", data):
        for part in re.finditer(rb"[A-Za-z0-9+/]+={0,2}", m.group(1)):
            if b64ok(part.group()):
                runs.append((m.start(1) + part.start(), m.start(1) + part.end()))
    return runs


def b64ok(run):
    try:
        base64.b64decode(run, validate=True)
    except (binascii.Error, ValueError):
        return False
    return len(run) % 4 == 0




#: what a number in a header becomes
HUGE = [b"2147483648", b"4294967296", b"9223372036854775808", b"18446744073709551616", b"1" + b"0" * 30,
        b"1e308", b"1e309", b"-1", b"-2147483649", b"0", b"1.5", b"-0.5", b"abc", b"nan", b"inf", b"-inf", b"",
        b"0x10", b"+7", b"99999999999999999999999999999999999999999999999999999999999999999999999999"]
_NUMBER = re.compile(rb"(?<![\w.+/-])[-+]?[0-9]+(?:\.[0-9]+)?(?:[eE][-+]?[0-9]+)?(?![\w.+/])")
#: words written over a zip header field
ZIP_VALUES = [0, 1, 2, 0x7FFF, 0xFFFF, 0x7FFFFFFF, 0xFFFFFFFF, 1000]
#: byte offset and width of the size/count fields of a local header, a central directory entry and the end record
ZIP_FIELDS = {b"PK\x03\x04": [(8, 2), (14, 4), (18, 4), (22, 4), (26, 2), (28, 2)],
              b"PK\x01\x02": [(10, 2), (16, 4), (20, 4), (24, 4), (28, 2), (30, 2), (32, 2), (42, 4)],
              b"PK\x05\x06": [(8, 2), (10, 2), (12, 4), (16, 4), (20, 2)]}
#: words written over the binary headers inside base64 (block counts and sizes)
WORDS = [0, 1, 3, 0x7FFFFFFF, 0xFFFFFFFF, 2**32, 2**62, 2**64 - 1]


def strategies_for(seed):
    """The damage strategies that apply to ``seed``."""
    names = ["truncate", "flip", "insert", "delete"]
    if _NUMBER.search(seed.data):
        names.append("number")
    if seed.text:
        names.append("lines")
    if seed.runs:
        names += ["payload", "base64"]
    if seed.zip:
        names.append("zip")
    return names


def damage(seed, strategy):
    """A hypothesis strategy of damaged copies of ``seed.data``."""
    data, n = seed.data, len(seed.data)
    at = st.integers(0, n - 1)
    if strategy == "truncate":
        return at.map(lambda k: data[:k])
    if strategy == "flip":
        return st.tuples(at, st.integers(1, 255)).map(lambda a: data[:a[0]] + bytes([data[a[0]] ^ a[1]])
                                                       + data[a[0] + 1:])
    if strategy == "insert":
        return st.tuples(st.integers(0, n), st.binary(min_size=1, max_size=8)).map(
            lambda a: data[:a[0]] + a[1] + data[a[0]:])
    if strategy == "delete":
        return st.tuples(at, st.integers(1, 16)).map(lambda a: data[:a[0]] + data[a[0] + a[1]:])
    if strategy == "number":
        spans = [m.span() for m in _NUMBER.finditer(data)]
        return st.tuples(st.sampled_from(spans), st.sampled_from(HUGE)).map(
            lambda a: data[:a[0][0]] + a[1] + data[a[0][1]:])
    if strategy == "lines":
        lines = data.splitlines(keepends=True)
        return st.tuples(st.sampled_from(["dup", "del", "swap"]), st.integers(0, len(lines) - 1)).map(
            lambda a: _lines(lines, *a))
    if strategy == "payload":
        return st.tuples(st.sampled_from(seed.runs), st.sampled_from(["flip", "truncate", "word4", "word8"]),
                         st.integers(0, 2**16), st.integers(0, 2**64 - 1)).map(lambda a: _payload(data, *a))
    if strategy == "base64":
        return st.tuples(st.sampled_from(seed.runs), st.integers(0, 2**16), st.sampled_from(list(b"!*= \n%A")),
                         st.booleans()).map(lambda a: _base64(data, *a))
    if strategy == "zip":
        return st.tuples(st.sampled_from(["field", "cd_flip", "member_flip", "member_cut", "no_end"]),
                         st.integers(0, 2**16), st.integers(0, 2**16), st.integers(1, 255)).map(
            lambda a: _zip(data, *a))
    raise ValueError(strategy)


def _lines(lines, op, i):
    lines = list(lines)
    if op == "dup":
        lines.insert(i, lines[i])
    elif op == "del":
        del lines[i]
    elif i + 1 < len(lines):
        lines[i], lines[i + 1] = lines[i + 1], lines[i]
    return b"".join(lines)


def _payload(data, run, op, pos, word):
    """Damage the bytes a base64 run holds (a zlib stream, a block header), then encode them again."""
    raw = bytearray(base64.b64decode(data[run[0]:run[1]]))
    pos %= max(len(raw), 1)
    if op == "flip" and raw:
        raw[pos] ^= 1 + word % 255
    elif op == "truncate":
        raw = raw[:pos]
    elif op in ("word4", "word8"):
        w = 4 if op == "word4" else 8
        pos -= pos % w
        raw[pos:pos + w] = (WORDS[word % len(WORDS)] % 2 ** (8 * w)).to_bytes(w, "little")
    return data[:run[0]] + base64.b64encode(bytes(raw)) + data[run[1]:]


def _base64(data, run, pos, char, replace):
    """A run of base64 with one character replaced or inserted."""
    k = run[0] + pos % (run[1] - run[0])
    return data[:k] + bytes([char]) + data[k + (1 if replace else 0):]


def _zip(data, op, a, b, xor):
    """A ZIP archive with a header field, the central directory or a member's data damaged."""
    heads = sorted((m.start(), sig) for sig in ZIP_FIELDS for m in re.finditer(re.escape(sig), data))
    cd = min((p for p, s in heads if s != b"PK\x03\x04"), default=len(data))
    if op == "field":
        pos, sig = heads[a % len(heads)]
        off, w = ZIP_FIELDS[sig][b % len(ZIP_FIELDS[sig])]
        value = ZIP_VALUES[xor % len(ZIP_VALUES)] % 2 ** (8 * w)
        return data[:pos + off] + value.to_bytes(w, "little") + data[pos + off + w:]
    if op == "cd_flip":
        k = cd + a % max(len(data) - cd, 1)
        return data[:k] + bytes([data[k] ^ xor]) + data[k + 1:] if k < len(data) else data
    if op == "no_end":
        return data[:data.rfind(b"PK\x05\x06")]
    # inside a member's data, past its 30-byte local header and name
    local = [p for p, s in heads if s == b"PK\x03\x04"]
    start = local[a % len(local)]
    body = start + 30 + struct.unpack("<H", data[start + 26:start + 28])[0]
    end = min([p for p, _ in heads if p > start] + [len(data)])
    if end <= body:
        return data
    k = body + b % (end - body)
    if op == "member_flip":
        return data[:k] + bytes([data[k] ^ xor]) + data[k + 1:]
    return data[:k] + data[min(k + xor, end):]  # member_cut: bytes removed, the directory not told




class LogRecords(logging.Handler):
    """Every log record of WARNING and above while it is attached to the root logger (nibabel logs its notes)."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.records = []

    def emit(self, record):
        self.records.append(record)

    def __enter__(self):
        logging.getLogger().addHandler(self)
        return self.records

    def __exit__(self, *exc):
        logging.getLogger().removeHandler(self)




@contextmanager
def peak_memory():
    """The most memory Python and numpy allocated at once in the block (tracemalloc, traced only there)."""
    import tracemalloc

    box = [0]
    tracemalloc.start()
    try:
        yield box
    finally:
        box[0] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()


def run_command(capfd, folder, args, inputs, outputs, read_back, *, check=False, exit1=False,
                most_memory=64 * 2**20, slow=SLOW, extra_files=()):
    """Run ``manifill ARGS`` in-process on the files ``inputs`` in ``folder``: ``(class, detail)``.

    ``class`` is ``'exit 0'``, ``'exit 1'`` (``check=True``: only ``check``'s failing condition; ``exit1=True``: a
    batch some of whose jobs did not finish), ``'exit 2'`` or
    ``'FAIL'``. After exit 0 the files ``outputs`` must exist and read back with ``read_back(path)`` (raising a
    manifill error otherwise); after any exit no other file may be left in ``folder`` (``extra_files``: names a
    command may write besides, such as a batch's summary, or a function of the folder giving them).
    """
    from manifill.console import main

    capfd.readouterr()
    with warnings.catch_warnings(record=True) as caught, LogRecords() as logged, peak_memory() as peak:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        try:
            code = main([str(a) for a in args])
        except BaseException as exc:  # noqa: BLE001 - main must not raise at all
            code, detail = None, f"main raised {type(exc).__name__}: {exc}"
        seconds = time.perf_counter() - t0
    out, err = capfd.readouterr()
    left = sorted(p.name for p in folder.iterdir())
    cls, detail = f"exit {code}", ""
    lines = err.splitlines()
    extra = extra_files(folder) if callable(extra_files) else extra_files
    allowed = sorted(set(inputs) | ({*outputs} if code == 0 else set()) | {n for n in extra if n in left})
    if code is None:
        cls = "FAIL"
    elif "Traceback" in out + err:
        cls, detail = "FAIL", f"a traceback: {err[-300:]!r}"
    elif code not in (0, 2) and not (code == 1 and (exit1 or (check and "FAILS" in out))):
        cls, detail = "FAIL", f"exit {code}: {err[:300]!r}"
    elif code == 2 and (len(lines) != 1 or not lines[0].startswith("manifill: error: ")):
        cls, detail = "FAIL", f"stderr is not one error line: {err[:300]!r}"
    elif code == 2 and "internal error" in err:
        cls, detail = "FAIL", f"an internal error: {err.strip()[:300]}"
    elif code == 2 and "memory" in err.lower() and not any(w in err for w in ("damaged", "needs about",
                                                                               "memory_limit")):
        cls, detail = "FAIL", f"speaks of memory for a small file: {err.strip()}"
    elif code != 2 and err and not (exit1 and code == 1 and len(lines) == 1 and lines[0].startswith("manifill: ")):
        cls, detail = "FAIL", f"exit {code} but stderr {err[:300]!r}"
    elif caught:
        cls, detail = "FAIL", f"warning escaped: {caught[0].category.__name__}: {caught[0].message}"
    elif logged:
        cls, detail = "FAIL", f"logged {logged[0].name}: {logged[0].getMessage()[:200]}"
    elif seconds > slow:
        cls, detail = "FAIL", f"took {seconds:.1f} s"
    elif peak[0] > most_memory:
        cls, detail = "FAIL", f"allocated {peak[0] / 2**20:.0f} MiB at once for inputs of a few kB"
    elif left != allowed:
        cls, detail = "FAIL", f"left files {left} after exit {code}"
    elif code == 0:
        for name in outputs:
            try:  # the output is complete: it reads back
                read_back(folder / name)
            except ManifillError as exc:
                cls, detail = "FAIL", f"the output {name} does not read back: {exc}"
    return cls, detail
