"""The decoder of VTK XML files: one parsed document and its DataArrays, in every encoding VTK writes.

:class:`VtkXmlDocument` reads the DataArrays of PolyData and ImageData files in each
of the ways VTK, ParaView and pyvista store them: ``ascii``, inline ``binary``
(base64) and ``appended`` (raw or base64, after the ``_`` of ``<AppendedData>``),
with a UInt32 or UInt64 header, either byte order, uncompressed or in zlib, LZMA
(or, with the ``lz4`` module, LZ4) blocks. Every count in a file is checked against
the bytes the file actually holds before anything is decoded, so a damaged or
truncated file ends in a one-line :class:`~manifill.errors.ReadError` naming it,
never in a huge allocation. The readers built on it are in
:mod:`manifill.io.vtkxml_read`, the writers in :mod:`manifill.io.vtkxml_write`.
"""

import base64
import binascii
import lzma
import re
import struct
import sys
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path

import numpy as np

from ..errors import ReadError

__all__ = ["VTK_TYPES", "MAX_COUNT", "VtkXmlDocument", "guarded"]

#: VTK XML type name -> little-endian numpy type string
VTK_TYPES = {"Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4", "UInt32": "u4",
             "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8"}
_COMPRESSORS = {None: None, "": None, "vtkZLibDataCompressor": "zlib", "vtkLZMADataCompressor": "lzma",
                "vtkLZ4DataCompressor": "lz4"}
#: any count beyond this cannot describe data in a file
MAX_COUNT = 2**62
_INT = re.compile(r"[+-]?[0-9]{1,19}")
_ZLIB_RATIO = 1032  # deflate never expands data more than this


class VtkXmlDocument:
    """A parsed VTK XML file: its element tree, header settings and appended data.

    Parameters
    ----------
    path : str or Path
    kind : str
        The dataset element it must hold (``"PolyData"``, ``"ImageData"``).
    label : str
        The format's name in messages (``"VTP"``, ``"VTI"``).

    Raises
    ------
    ReadError
        A missing or unreadable file, malformed XML, another dataset kind, or an
        unknown byte order, header type, compressor or appended encoding.
    """

    def __init__(self, path, kind, label):
        self.path = Path(path)
        self.name = self.path.name
        self.label = label
        if not self.path.is_file():
            raise ReadError(f"{self.path}: no such file")
        try:
            data = self.path.read_bytes()
        except OSError as exc:
            raise self.fail(f"could not read ({exc}); check the file's permissions") from None
        xml, self.appended = self._split(data)
        try:
            self.root = ET.fromstring(xml)
        except (ET.ParseError, LookupError, ValueError) as exc:  # LookupError, ValueError: the declared encoding
            raise self.fail(f"not a readable {label} file ({exc}); check the file") from None
        if self.root.tag != "VTKFile" or self.root.find(kind) is None or self.root.get("type") != kind:
            found = self.root.get("type") or self.root.tag
            raise self.fail(f"not VTK {kind} (the file holds {found}); pass a .{label.lower()} file")
        self.body = self.root.find(kind)
        order = self.root.get("byte_order", "LittleEndian")
        if order not in ("LittleEndian", "BigEndian"):
            raise self.fail(f"byte_order {order!r} is neither LittleEndian nor BigEndian; check the file")
        self.endian = "<" if order == "LittleEndian" else ">"
        htype = self.root.get("header_type", "UInt32")
        if htype not in ("UInt32", "UInt64"):
            raise self.fail(f"header_type {htype!r} is neither UInt32 nor UInt64; check the file")
        self.header = np.dtype(self.endian + VTK_TYPES[htype])
        comp = self.root.get("compressor")
        if comp not in _COMPRESSORS:
            raise self.fail(f"compressor {comp!r} is unknown; re-save the file with zlib compression or none")
        self.compressor = _COMPRESSORS[comp]
        if self.appended is not None:
            enc = self.root.find("AppendedData")
            enc = None if enc is None else enc.get("encoding", "raw")
            if enc == "base64":
                try:
                    self.appended = self.appended.decode("ascii")
                except UnicodeDecodeError:
                    raise self.fail("the base64 AppendedData holds non-ASCII bytes; the file is damaged") from None
            elif enc != "raw":
                raise self.fail(f"AppendedData encoding {enc!r} is neither raw nor base64; check the file")

    def fail(self, msg):
        """A one-line ReadError naming the file."""
        return ReadError(f"{self.name}: " + " ".join(str(msg).split()))

    def _split(self, data):
        """Split the raw ``<AppendedData>`` payload off: (XML bytes, payload bytes or None)."""
        start = data.find(b"<AppendedData")
        if start < 0:
            return data, None
        gt = data.find(b">", start)
        mark = data.find(b"_", gt) if gt >= 0 else -1
        if mark < 0 or data[gt + 1:mark].strip():
            raise self.fail("the AppendedData section has no '_' marker; the file is damaged or truncated")
        end = data.rfind(b"</AppendedData>")
        if end < mark:
            raise self.fail("the AppendedData section is not closed; the file is truncated")
        return data[:gt + 1] + data[end:], data[mark + 1:end]

    # -- attributes ---------------------------------------------------------

    def count(self, elem, attr, default=None):
        """A non-negative integer attribute."""
        text = elem.get(attr)
        if text is None and default is not None:
            return default
        return self.ints(text, 1, f"{elem.tag} {attr}")[0]

    def ints(self, text, k, what, signed=False):
        """``k`` integers from an attribute's text."""
        words = (text or "").split()
        if len(words) != k or not all(_INT.fullmatch(w) for w in words):
            raise self.fail(f"{what} {text!r} is not {k if k > 1 else 'an'} integer{'s' if k > 1 else ''}; "
                            f"check the file")
        vals = [int(w) for w in words]
        if any(abs(v) > MAX_COUNT or (v < 0 and not signed) for v in vals):
            raise self.fail(f"{what} {text!r} is {'absurd' if signed else 'negative or absurd'}; check the file")
        return vals

    def floats(self, elem, attr, k, default):
        """``k`` finite floats from an attribute."""
        text = elem.get(attr, default)
        try:
            vals = np.array([float(w) for w in text.split()], dtype=np.float64)
        except ValueError:
            raise self.fail(f"{self.label} with a malformed {attr} {text!r}; check the file") from None
        if vals.size != k or not np.isfinite(vals).all():
            raise self.fail(f"{attr} {text!r} is not {k} finite numbers; check the file")
        return vals

    # -- data arrays --------------------------------------------------------

    def array(self, da, what):
        """Decode one DataArray: (flat values in native byte order, number of components, name)."""
        name = da.get("Name")
        label = f"DataArray {name!r}" + (f" of {what}" if what else "")
        kind, fmt = da.get("type"), da.get("format", "ascii")
        if kind not in VTK_TYPES:
            raise self.fail(f"{label} has type {kind}; only numeric arrays (Int8 ... Float64) are read, "
                            f"remove it or convert it")
        p = self.count(da, "NumberOfComponents", 1)
        if p < 1:
            raise self.fail(f"{label} has NumberOfComponents=0; check the file")
        dt = np.dtype(self.endian + VTK_TYPES[kind])
        if fmt == "ascii":
            words = (da.text or "").split()
            try:
                values = np.array(words, dtype=dt.newbyteorder("="))
            except (ValueError, OverflowError):
                raise self.fail(f"{label} holds a value that is not of type {kind}; check the file") from None
            return values, p, name
        if fmt == "binary":
            raw = self.b64_array(re.sub(r"\s+", "", da.text or ""), 0, label)
        elif fmt == "appended":
            if self.appended is None:
                raise self.fail(f"{label} is appended but the file has no AppendedData section; it is damaged")
            offset = self.count(da, "offset", 0)
            if offset >= max(len(self.appended), 1):
                raise self.fail(f"{label} has offset {offset} outside the appended data "
                                f"({len(self.appended)} bytes); the file is damaged")
            if isinstance(self.appended, str):
                raw = self.b64_array(self.appended, offset, label)
            else:
                raw = self.raw_array(memoryview(self.appended), offset, label)
        else:
            raise self.fail(f"{label} has format {fmt!r}; use ascii, binary or appended")
        if len(raw) % dt.itemsize:
            raise self.fail(f"{label} holds {len(raw)} bytes, not a whole number of {kind} values; "
                            f"the file is damaged")
        return np.frombuffer(raw, dtype=dt).astype(dt.newbyteorder("=")), p, name

    def header_ints(self, raw, k, label):
        hs = self.header.itemsize
        if len(raw) < k * hs:
            raise self.fail(f"{label} has a truncated header ({len(raw)} of {k * hs} bytes); the file is damaged")
        return np.frombuffer(raw, dtype=self.header, count=k).astype(np.uint64)

    def raw_array(self, buf, pos, label):
        """The data of the array at byte ``pos`` of the raw appended section (decompressed)."""
        hs = self.header.itemsize
        if self.compressor is None:
            nbytes = int(self.header_ints(buf[pos:pos + hs], 1, label)[0])
            avail = len(buf) - pos - hs
            if nbytes > avail:
                raise self.fail(f"{label}: header claims {nbytes} bytes but the file has only {max(avail, 0)} "
                                f"bytes there; it is truncated or damaged")
            return bytes(buf[pos + hs:pos + hs + nbytes])
        nb, bs, lbs = (int(v) for v in self.header_ints(buf[pos:pos + 3 * hs], 3, label))
        self._check_blocks(nb, len(buf) - pos - 3 * hs, hs, label)
        sizes = self.header_ints(buf[pos + 3 * hs:pos + (3 + nb) * hs], nb, label)
        start = pos + (3 + nb) * hs
        total = self._check_sizes(sizes, len(buf) - start, label)
        return self.inflate(buf[start:start + total], sizes, nb, bs, lbs, label)

    def b64_array(self, text, pos, label):
        """The data of the base64 array starting at character ``pos`` (decompressed).

        VTK encodes the header on its own before compressed data and in one stream with
        uncompressed data; both (and a header on its own before uncompressed data) read.
        """
        hs = self.header.itemsize
        if self.compressor is None:
            hb = hs
            nbytes = int(self.header_ints(self.b64(text, pos, hs, label), 1, label)[0])
        else:
            nb, bs, lbs = (int(v) for v in self.header_ints(self.b64(text, pos, 3 * hs, label), 3, label))
            self._check_blocks(nb, (len(text) - pos) * 3 // 4 - 3 * hs, hs, label)
            hb = (3 + nb) * hs
            sizes = self.header_ints(self.b64(text, pos, hb, label)[3 * hs:], nb, label)
            nbytes = self._check_sizes(sizes, (len(text) - pos) * 3 // 4 - hb, label)
        avail = (len(text) - pos) * 3 // 4 - hb
        if nbytes > avail:
            raise self.fail(f"{label}: header claims {nbytes} bytes but the file has only {max(avail, 0)} "
                            f"bytes of base64 there; it is truncated or damaged")
        hc = _b64_chars(hb)
        if hb % 3 and text[pos + hc - 1:pos + hc] == "=":  # header encoded on its own
            body = self.b64(text, pos + hc, nbytes, label)
        else:
            body = self.b64(text, pos, hb + nbytes, label)[hb:]
        if self.compressor is None:
            return body
        return self.inflate(memoryview(body), sizes, nb, bs, lbs, label)

    def b64(self, text, pos, nbytes, label):
        """The first ``nbytes`` bytes of the base64 stream starting at character ``pos``."""
        nchars = _b64_chars(nbytes)
        chunk = text[pos:pos + nchars]
        if len(chunk) < nchars:
            raise self.fail(f"{label}: header claims {nbytes} bytes but the file has only "
                            f"{max(len(text) - pos, 0) * 3 // 4} bytes of base64 there; it is truncated or damaged")
        try:
            raw = base64.b64decode(chunk, validate=True)
        except (binascii.Error, ValueError) as exc:
            raise self.fail(f"{label} is not valid base64 ({exc}); the file is damaged") from None
        if len(raw) < nbytes:
            raise self.fail(f"{label}: header claims {nbytes} bytes but its base64 ends after {len(raw)}; "
                            f"the file is damaged")
        return raw[:nbytes]

    def _check_blocks(self, nb, avail, hs, label):
        if nb * hs > avail:
            raise self.fail(f"{label}: header claims {nb} compressed blocks but the file has only "
                            f"{max(avail, 0)} bytes there; it is truncated or damaged")

    def _check_sizes(self, sizes, avail, label):
        biggest = int(sizes.max()) if sizes.size else 0
        total = sum(sizes.tolist()) if biggest <= avail else biggest
        if total > avail:
            raise self.fail(f"{label}: header claims {total} compressed bytes but the file has only "
                            f"{max(avail, 0)} bytes there; it is truncated or damaged")
        return total

    def inflate(self, buf, sizes, nb, bs, lbs, label):
        """Decompress ``nb`` blocks of ``bs`` bytes (the last ``lbs``, or ``bs`` if 0) stored back to back."""
        out, pos = [], 0
        for i in range(nb):
            want = bs if i < nb - 1 or lbs == 0 else lbs
            c = int(sizes[i])
            out.append(self._decompress(buf[pos:pos + c], want, f"{label} block {i}"))
            pos += c
        return b"".join(out)

    def _decompress(self, block, want, label):
        """One compressed block, which must hold exactly ``want`` bytes (never more are produced)."""
        ratio = {"zlib": _ZLIB_RATIO, "lz4": 255, "lzma": None}[self.compressor]
        if want >= sys.maxsize or (ratio and want > ratio * len(block) + 64):
            raise self.fail(f"{label}: header claims {want} bytes from {len(block)} compressed bytes; "
                            f"the file is damaged")
        if self.compressor == "lz4":
            data, ended = self._lz4(block, want, label), True
        else:
            zlib_ = self.compressor == "zlib"
            dec = zlib.decompressobj() if zlib_ else lzma.LZMADecompressor()
            try:
                data = dec.decompress(block, want + 1)  # one byte more than claimed shows a lying header
            except (zlib.error, lzma.LZMAError) as exc:
                raise self.fail(f"{label} is not a valid {'zlib' if zlib_ else 'LZMA'} stream ({exc}); "
                                f"the file is damaged") from None
            ended = dec.eof and not dec.unused_data
        if len(data) != want or not ended:
            raise self.fail(f"{label} does not decompress to the {want} bytes its header claims; "
                            f"the file is damaged")
        return data

    def _lz4(self, block, want, label):
        try:
            import lz4.block
        except ImportError:
            raise self.fail("is LZ4-compressed, which needs the lz4 module; install it (pip install lz4) or "
                            "re-save the file with zlib compression") from None
        try:
            return lz4.block.decompress(bytes(block), uncompressed_size=want)
        except (lz4.block.LZ4BlockError, ValueError) as exc:
            raise self.fail(f"{label} is not a valid LZ4 block ({exc}); the file is damaged") from None

    def check_size(self, values, n, p, label, what="points"):
        if values.size != n * p:
            per = f" of {p} components" if p > 1 else ""
            raise self.fail(f"{label} has {values.size} values for {n} {what}{per}; check the file")

    def point_data(self, piece, n):
        """The named point fields of one piece: dict name -> (n, p) array."""
        out = {}
        pd = piece.find("PointData")
        for k, da in enumerate(pd.findall("DataArray") if pd is not None else ()):
            values, p, name = self.array(da, "PointData")
            self.check_size(values, n, p, f"DataArray {name!r}")
            key = name if name is not None else f"array{k}"
            while key in out:
                key = f"{key} ({k})"
            out[key] = values.reshape(n, p)
        return out


def _b64_chars(nbytes):
    return 4 * ((nbytes + 2) // 3)


def guarded(reader, path, label):
    """Run ``reader`` and turn any remaining low-level failure on a damaged file into a one-line ReadError.

    Parameters
    ----------
    reader : callable
        Takes no argument; its result is returned.
    path : str or Path
        The file read (for the message).
    label : str
        The format's name (``"VTP"``).

    Raises
    ------
    ReadError
        Any ValueError, MemoryError, decoding error ... of ``reader``, as one line naming the file.
    """
    try:
        return reader()
    except ReadError:
        raise
    except MemoryError:
        raise ReadError(f"{Path(path).name}: not a readable {label} file (a size in it is implausible); "
                        f"the file is damaged") from None
    except (ValueError, TypeError, IndexError, KeyError, OverflowError, struct.error, zlib.error, lzma.LZMAError,
            binascii.Error, UnicodeDecodeError) as exc:
        msg = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise ReadError(f"{Path(path).name}: not a readable {label} file ({msg}); the file is damaged") from None

