"""The scanner under the legacy VTK reader: lines, counts and arrays of a ``.vtk`` file, each checked.

:class:`LegacyScanner` is a cursor over the bytes of one file: header lines and
their counts, ASCII or (big-endian) BINARY arrays of any legacy VTK type, string
arrays read past. No count is trusted: each is checked against the bytes that
follow before anything is allocated, and every failure is one
:class:`~manifill.errors.ReadError` naming the file. The sections of a mesh are
read by :mod:`manifill.io.vtklegacy_read`.
"""

import re

import numpy as np

from ..errors import ReadError

__all__ = ["LEGACY_TYPES", "MAX_COUNT", "LegacyScanner", "decode_name", "quoted", "quoted_line"]

#: legacy VTK type name (lower case) -> numpy type string without byte order
LEGACY_TYPES = {
    "unsigned_char": "u1", "char": "i1", "signed_char": "i1", "short": "i2", "unsigned_short": "u2",
    "int": "i4", "unsigned_int": "u4", "long": "i8", "unsigned_long": "u8", "vtkidtype": "i4",
    "float": "f4", "double": "f8",
    "vtktypeint8": "i1", "vtktypeuint8": "u1", "vtktypeint16": "i2", "vtktypeuint16": "u2",
    "vtktypeint32": "i4", "vtktypeuint32": "u4", "vtktypeint64": "i8", "vtktypeuint64": "u8",
    "vtktypefloat32": "f4", "vtktypefloat64": "f8",
}
_STRING_TYPES = ("string", "utf8_string")
#: the largest count legacy VTK holds (its counts are 32-bit)
MAX_COUNT = 2**31 - 1
_LONGEST = 64  # characters of the longest ASCII number read
_INT = re.compile(rb"[+-]?[0-9]+")
_ESCAPE = re.compile(rb"%([0-9A-Fa-f]{2})")


class LegacyScanner:
    """A cursor over the bytes of one legacy VTK file.

    Parameters
    ----------
    name : str
        The file's name (for messages).
    data : bytes
        Its whole content.
    """

    def __init__(self, name, data):
        self.name, self.data, self.pos = name, data, 0
        self.binary = False

    def fail(self, msg, fix="check the file"):
        """Raise the one-line ReadError ``name: msg; fix``."""
        raise ReadError(f"{self.name}: {msg}; {fix}")

    # -- lines and counts ---------------------------------------------------

    def raw_line(self):
        """The next line (bytes, without its line break), or None at the end."""
        if self.pos >= len(self.data):
            return None
        end = self.data.find(b"\n", self.pos)
        end = len(self.data) if end < 0 else end
        text = self.data[self.pos:end]
        self.pos = end + 1
        return text

    def line(self):
        """The words of the next non-blank line, or None at the end."""
        while True:
            text = self.raw_line()
            if text is None:
                return None
            words = text.split()
            if words:
                return words

    def count(self, words, i, what, least=0):
        """Word ``i`` of a header line as a count in ``least..2**31-1``."""
        if len(words) <= i:
            self.fail(f"the {quoted_line(words)} line lacks its {what}")
        word = words[i]
        if not _INT.fullmatch(word):
            self.fail(f"the {quoted_line(words)} line gives {what} {quoted(word)}, which is not a whole number")
        value = int(word) if len(word) <= 30 else None
        if value is None or not least <= value <= MAX_COUNT:
            self.fail(f"the {quoted_line(words)} line gives {what} {quoted(word)}, outside {least}..{MAX_COUNT}")
        return value

    def at(self, keyword):
        """Whether the next non-blank text starts with ``keyword`` (a lower-case word), without moving on."""
        head = self.data[self.pos:self.pos + 256].lstrip()[:len(keyword) + 1]
        return head[:len(keyword)].lower() == keyword and (len(head) == len(keyword) or head[-1:].isspace())

    def skip_metadata(self):
        """Read past a METADATA or INFORMATION block: up to and with its blank line."""
        while True:
            text = self.raw_line()
            if text is None or not text.strip():
                return

    # -- arrays -------------------------------------------------------------

    def dtype(self, vtype, what):
        """The numpy type of a VTK type name, or ReadError."""
        kind = vtype.decode("latin-1").lower()
        if kind == "bit":
            self.fail(f"{what} has type bit, which is not supported", "re-export it as unsigned_char")
        if kind not in LEGACY_TYPES:
            self.fail(f"{what} has the unknown data type {quoted(vtype)}")
        return np.dtype(LEGACY_TYPES[kind])

    def values(self, dt, count, what):
        """``count`` values of numpy type ``dt`` from here on (after a header line)."""
        if count == 0:
            return np.zeros(0, dtype=dt)
        left = len(self.data) - self.pos
        if self.binary:
            need = count * dt.itemsize
            if need > left:
                self.fail(f"header claims {what} ({need:,} bytes) but only {max(left, 0):,} bytes follow",
                          "the file is truncated or its header is wrong; check or re-export it")
            arr = np.frombuffer(self.data, dtype=dt.newbyteorder(">"), count=count, offset=self.pos)
            self.pos += need
            return arr.astype(dt)
        if 2 * count - 1 > left:
            self.fail(f"header claims {what} ({count:,} numbers) but only {max(left, 0):,} bytes follow",
                      "the file is truncated or its header is wrong; check or re-export it")
        return self.parse(self.tokens(count, what), dt, what)

    def tokens(self, count, what):
        """The next ``count`` whitespace-separated words of ASCII data."""
        data, pos = self.data, self.pos
        window = 32 * count + 64
        while True:
            chunk = data[pos:pos + window]
            words = chunk.split(None, count)
            at_end = pos + window >= len(data)
            if len(words) > count or at_end:
                break
            window *= 4
        if len(words) < count:
            self.fail(f"header claims {what} ({count:,} numbers) but the file ends after {len(words):,}",
                      "the file is truncated or its header is wrong; check or re-export it")
        if len(words) > count:
            self.pos = pos + len(chunk) - len(words[count])
            del words[count]
        else:
            self.pos = len(data)
        return words

    def parse(self, words, dt, what):
        """ASCII words as numbers of numpy type ``dt``, each checked to parse and to fit."""
        longest = max(words, key=len)
        if len(longest) > _LONGEST:  # no number is this long; and one such word would make every row as wide
            self.fail(f"{what} holds {quoted(longest)}, which is not a number")
        text = np.array(words)
        if dt.kind == "f":
            try:
                out = text.astype(np.float64)
            except ValueError:
                self.fail(f"{what} holds {_first_bad(words, np.float64)}, which is not a number")
            with np.errstate(over="ignore"):
                return out.astype(dt)
        wide = np.uint64 if dt == np.uint64 else np.int64
        try:
            out = text.astype(wide)
        except (ValueError, OverflowError):
            self.fail(f"{what} holds {_first_bad(words, wide)}, which is not an integer of its type {dt}")
        info = np.iinfo(dt)
        bad = (out < info.min) | (out > info.max)
        if bad.any():
            self.fail(f"{what} holds {out[bad][0]}, which does not fit its type {dt}")
        return out.astype(dt)

    def array(self, vtype, tuples, comps, what):
        """An array of ``tuples`` x ``comps`` values, or None for a (skipped) string array."""
        if vtype.decode("latin-1").lower() in _STRING_TYPES:
            self.skip_strings(tuples * comps, what)
            return None
        dt = self.dtype(vtype, what)
        arr = self.values(dt, tuples * comps, what)
        if vtype.lower() == b"vtkidtype":  # stored as 4 bytes, held as 64-bit ids, as in VTK
            arr = arr.astype(np.int64)
        return arr if comps == 1 else arr.reshape(tuples, comps)

    def skip_strings(self, count, what):
        """Read past ``count`` strings (one a line in ASCII, length-prefixed in binary)."""
        left = len(self.data) - self.pos
        if count > left:
            self.fail(f"header claims {what} ({count:,} strings) but only {max(left, 0):,} bytes follow",
                      "the file is truncated or its header is wrong; check or re-export it")
        data = self.data
        for _ in range(count):
            if self.binary:
                if self.pos >= len(data):
                    self.fail(f"{what} ends inside its strings", "the file is truncated; re-export it")
                head = data[self.pos] >> 6
                width = {3: 1, 2: 2, 1: 4, 0: 8}[head]
                raw = data[self.pos:self.pos + width]
                if len(raw) < width:
                    self.fail(f"{what} ends inside its strings", "the file is truncated; re-export it")
                length = int.from_bytes(raw, "big") & ((1 << (8 * width - (2 if width < 8 else 0))) - 1)
                self.pos += width + length
                if self.pos > len(data):
                    self.fail(f"{what} has a string of {length:,} bytes past the end of the file",
                              "the file is truncated; re-export it")
            elif self.raw_line() is None:
                self.fail(f"{what} ends inside its strings", "the file is truncated; re-export it")

    def int_array(self, vtype, count, what):
        """``count`` values of an integer VTK type as int64 (offsets, connectivity)."""
        dt = self.dtype(vtype, what)
        if dt.kind not in "iu":
            self.fail(f"{what} have type {quoted(vtype)}, not an integer type")
        return self.values(dt, count, what).astype(np.int64)


def decode_name(word):
    """An array name (bytes) with VTK's ``%XX`` escapes decoded, as text."""
    raw = _ESCAPE.sub(lambda m: bytes([int(m.group(1), 16)]), word)
    return raw.decode("utf-8", errors="replace")


def quoted(word, limit=40):
    """A word (bytes or text) for a message: quoted, at most ``limit`` characters."""
    text = word.decode("latin-1") if isinstance(word, bytes) else str(word)
    return repr(text if len(text) <= limit else text[:limit] + "...")


def quoted_line(words):
    """A header line for a message: quoted, at most 60 characters, on one line."""
    return quoted(b" ".join(words), 60)


def _first_bad(words, dt):
    """The first word that does not parse as a value of numpy type ``dt`` (for a message)."""
    for w in words:
        try:
            np.array([w]).astype(dt)
        except (ValueError, OverflowError):
            return quoted(w)
    return "a value out of range"
