"""VTK XML files: PolyData (``.vtp``) and ImageData (``.vti``), read in every encoding, written compressed.

One decoder reads the DataArrays of both kinds, in each of the ways VTK, ParaView and
pyvista store them: ``ascii``, inline ``binary`` (base64) and ``appended`` (raw or
base64, after the ``_`` of ``<AppendedData>``), with a UInt32 or UInt64 header,
either byte order, uncompressed or in zlib, LZMA (or, with the ``lz4`` module, LZ4)
blocks, over one or several ``<Piece>`` elements. Every count in a file is checked
against the bytes the file actually holds before anything is decoded, so a damaged
or truncated file ends in a one-line :class:`~manifill.errors.ReadError` naming it,
never in a huge allocation. The writers store zlib-compressed inline binary arrays
that VTK, ParaView and pyvista open, and write atomically as :mod:`manifill.io.registry` does.
"""

import base64
import binascii
import lzma
import re
import struct
import sys
import unicodedata
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path

import numpy as np

from ..errors import ReadError, WriteError
from .registry import atomic_path

__all__ = ["read_polydata", "read_imagedata", "write_polydata", "write_unstructured", "write_imagedata"]

#: VTK XML type name -> little-endian numpy type string
_TYPES = {"Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4", "UInt32": "u4",
          "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8"}
_VTK_NAMES = {np.dtype(v).newbyteorder("="): k for k, v in _TYPES.items()}
_COMPRESSORS = {None: None, "": None, "vtkZLibDataCompressor": "zlib", "vtkLZMADataCompressor": "lzma",
                "vtkLZ4DataCompressor": "lz4"}
_MAX_COUNT = 2**62  # any count beyond this cannot describe data in a file
_INT = re.compile(r"[+-]?[0-9]{1,19}")
_BLOCK = 1 << 20  # uncompressed bytes per zlib block in written files
_LEVEL = 5  # VTK's default zlib level
_ZLIB_RATIO = 1032  # deflate never expands data more than this


# ---------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------


class _Doc:
    """A parsed VTK XML file: its element tree, header settings and appended data."""

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
        self.header = np.dtype(self.endian + _TYPES[htype])
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
        if any(abs(v) > _MAX_COUNT or (v < 0 and not signed) for v in vals):
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
        if kind not in _TYPES:
            raise self.fail(f"{label} has type {kind}; only numeric arrays (Int8 ... Float64) are read, "
                            f"remove it or convert it")
        p = self.count(da, "NumberOfComponents", 1)
        if p < 1:
            raise self.fail(f"{label} has NumberOfComponents=0; check the file")
        dt = np.dtype(self.endian + _TYPES[kind])
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


def _guarded(reader, path, label):
    """Run ``reader`` and turn any remaining low-level failure on a damaged file into a one-line ReadError."""
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


def _merge(doc, pieces, label):
    """Concatenate per-piece field dicts (pieces without points do not count)."""
    pieces = [pd for n, pd in pieces if n]
    if not pieces:
        return {}
    first = pieces[0]
    for pd in pieces[1:]:
        if list(pd) != list(first) or any(pd[k].shape[1] != first[k].shape[1] or pd[k].dtype != first[k].dtype
                                          for k in pd):
            raise doc.fail(f"its pieces hold different {label}; check the file")
    return {k: np.concatenate([pd[k] for pd in pieces]) for k in first}


def _cells(doc, piece, tag, n):
    """(starts, sizes, connectivity) of the cells of one cell-array element of a piece."""
    m = doc.count(piece, f"NumberOf{tag}", 0)
    elem = piece.find(tag)
    if elem is None:
        if m:
            raise doc.fail(f"Piece claims {m} {tag} but has no <{tag}> element; the file is damaged")
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    arrays = {da.get("Name"): da for da in elem.findall("DataArray")}
    got = {}
    for key in ("connectivity", "offsets"):
        if key not in arrays:
            raise doc.fail(f"<{tag}> has no DataArray {key!r}; the file is damaged")
        values, _, _ = doc.array(arrays[key], tag)
        if values.dtype.kind not in "iu":
            raise doc.fail(f"DataArray {key!r} of {tag} holds {values.dtype} values, not integers; check the file")
        if values.size and (int(values.max()) > _MAX_COUNT or int(values.min()) < 0):
            raise doc.fail(f"DataArray {key!r} of {tag} holds values outside 0..{_MAX_COUNT} "
                           f"({int(values.min())} .. {int(values.max())}); the file is damaged")
        got[key] = values.astype(np.int64)
    conn, offs = got["connectivity"], got["offsets"]
    if offs.size == m + 1 and offs[0] == 0:  # offsets with the leading 0
        offs = offs[1:]
    if offs.size != m:
        raise doc.fail(f"DataArray 'offsets' of {tag} has {offs.size} values for {m} cells; check the file")
    ends = offs
    starts = np.concatenate([[0], ends[:-1]]) if m else ends
    if m and (np.any(ends < starts) or ends[-1] != conn.size):
        raise doc.fail(f"DataArray 'offsets' of {tag} is not increasing up to the {conn.size} connectivity "
                       f"entries; the file is damaged")
    if not m and conn.size:
        raise doc.fail(f"<{tag}> has {conn.size} connectivity entries but no cells; the file is damaged")
    if conn.size and int(conn.max()) >= n:
        raise doc.fail(f"DataArray 'connectivity' of {tag} refers to point {int(conn.max())} of a piece with "
                       f"{n} points (indices 0..{n - 1}); the file is damaged")
    return starts, ends - starts, conn


def _fan(starts, sizes, conn):
    """Triangles (v0, vi, vi+1) of each polygon; polygons of fewer than 3 vertices give none."""
    k = np.maximum(sizes - 2, 0)
    cell = np.repeat(np.arange(len(k)), k)
    local = np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k) + 1
    s = starts[cell]
    return np.column_stack([conn[s], conn[s + local], conn[s + local + 1]])


def _strips(starts, sizes, conn):
    """Triangles of each strip, every second one flipped so all keep the strip's orientation."""
    k = np.maximum(sizes - 2, 0)
    cell = np.repeat(np.arange(len(k)), k)
    i = np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)
    a = starts[cell] + i
    odd = (i % 2).astype(bool)
    tri = np.column_stack([conn[a], conn[a + 1], conn[a + 2]])
    tri[odd, 0], tri[odd, 1] = conn[a[odd] + 1], conn[a[odd]]
    return tri


def read_polydata(path):
    """Read the triangles, points and named point fields of a VTK PolyData file (``.vtp``).

    Any encoding VTK writes reads: ascii, inline binary or appended (raw or base64),
    uncompressed or compressed (zlib, LZMA; LZ4 with the ``lz4`` module), UInt32 or
    UInt64 headers, either byte order, several pieces (concatenated).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    V : (n, 3) float64 numpy array
        Point positions (2-component points get ``z = 0``).
    F : (m, 3) int64 numpy array
        Triangles: the polygons fan-triangulated (polygons of fewer than 3 vertices
        are skipped), then the triangle strips, split keeping their orientation.
        Vertices and lines are ignored.
    point_data : dict of str to (n,) or (n, p) numpy array
        The point fields, in their stored dtype (native byte order).

    Raises
    ------
    ReadError
        A missing or damaged file, not PolyData, or no triangle in it.

    Examples
    --------
    >>> import tempfile, os
    >>> f = os.path.join(tempfile.mkdtemp(), "t.vtp")
    >>> write_polydata(f, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], {"u": np.array([1, 2, 3])})
    >>> V, F, data = read_polydata(f)
    >>> F.tolist(), data["u"].tolist(), data["u"].dtype
    ([[0, 1, 2]], [1, 2, 3], dtype('int32'))
    """
    return _guarded(lambda: _read_polydata(path), path, "VTP")


def _read_polydata(path):
    doc = _Doc(path, "PolyData", "VTP")
    Vs, Fs, fields, base = [], [], [], 0
    for piece in doc.body.findall("Piece"):
        n = doc.count(piece, "NumberOfPoints", 0)
        pts = piece.find("Points")
        das = [] if pts is None else pts.findall("DataArray")
        if not das:
            if n:
                raise doc.fail(f"Piece claims {n} points but has no <Points> array; the file is damaged")
            V = np.zeros((0, 3))
        else:
            values, p, _ = doc.array(das[0], "Points")
            if p not in (2, 3):
                raise doc.fail(f"Points have {p} components; pass 2-D or 3-D points")
            doc.check_size(values, n, p, "the Points array")
            V = values.reshape(n, p).astype(np.float64)
            if p == 2:
                V = np.column_stack([V, np.zeros(n)])
        fields.append((n, doc.point_data(piece, n)))
        tris = [_fan(*_cells(doc, piece, "Polys", n)), _strips(*_cells(doc, piece, "Strips", n))]
        Vs.append(V)
        Fs.extend(t + base for t in tris)
        base += n
    F = np.concatenate(Fs).astype(np.int64) if Fs else np.zeros((0, 3), np.int64)
    if not len(F):
        raise doc.fail("holds no triangles (no polygon of 3 or more vertices, no triangle strip); "
                       "pass a surface mesh")
    data = _merge(doc, fields, "point fields")
    data = {k: v[:, 0] if v.shape[1] == 1 else v for k, v in data.items()}
    return np.concatenate(Vs), F, data


def read_imagedata(path):
    """Read the point fields of VTK ImageData (``.vti``) as voxel arrays.

    Any encoding VTK writes reads, as for :func:`read_polydata`; several pieces are
    assembled into the whole extent. Cell data is not a voxel field and is left out.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    fields : dict of str to (n0, n1, n2) or (n0, n1, n2, p) numpy array
        Indexed ``(i, j, k)`` (the file stores x fastest), in the stored dtype.
    spacing, origin : (3,) float64 numpy arrays
        The voxel size and the position of voxel ``(0, 0, 0)`` (``Origin`` moved to
        the start of ``WholeExtent``).

    Raises
    ------
    ReadError
        A missing or damaged file, not ImageData, or a ``Direction`` that is not
        the identity.
    """
    return _guarded(lambda: _read_imagedata(path), path, "VTI")


def _read_imagedata(path):
    doc = _Doc(path, "ImageData", "VTI")
    img = doc.body
    if img.get("WholeExtent") is None or len(img.get("WholeExtent").split()) != 6:
        raise doc.fail(f"ImageData without a WholeExtent of 6 numbers (got {img.get('WholeExtent')!r}); "
                       f"check the file")
    try:
        whole = doc.ints(img.get("WholeExtent"), 6, "WholeExtent", signed=True)
    except ReadError:
        raise doc.fail(f"ImageData with a malformed WholeExtent {img.get('WholeExtent')!r}; check the file") from None
    spacing = doc.floats(img, "Spacing", 3, "1 1 1")
    origin = doc.floats(img, "Origin", 3, "0 0 0")
    direction = doc.floats(img, "Direction", 9, "1 0 0 0 1 0 0 0 1")
    if np.abs(direction - np.eye(3).ravel()).max() > 1e-12:
        raise doc.fail("has a Direction that is not the identity (a rotated grid); resample it onto an axis-aligned "
                       "grid first")
    lo, hi = np.array(whole[0::2]), np.array(whole[1::2])
    shape = tuple(int(v) for v in hi - lo + 1)
    if min(shape) < 1:
        raise doc.fail(f"WholeExtent {img.get('WholeExtent')!r} is empty; check the file")
    pieces = []
    for piece in img.findall("Piece"):
        ext = doc.ints(piece.get("Extent", img.get("WholeExtent")), 6, "Piece Extent", signed=True)
        plo, phi = np.array(ext[0::2]), np.array(ext[1::2])
        if np.any(plo < lo) or np.any(phi > hi) or np.any(phi < plo):
            raise doc.fail(f"Piece Extent {' '.join(map(str, ext))} is not inside WholeExtent "
                           f"{' '.join(map(str, whole))}; check the file")
        pshape = tuple(int(v) for v in phi - plo + 1)
        pd = doc.point_data(piece, int(np.prod(pshape, dtype=object)))
        # x fastest in the file: reverse to (k, j, i, p), then move to (i, j, k, p)
        pd = {k: np.moveaxis(v.reshape(pshape[::-1] + (v.shape[1],)), (0, 1, 2), (2, 1, 0)) for k, v in pd.items()}
        pieces.append((plo - lo, pshape, pd))
    fields = {}
    if len(pieces) == 1 and pieces[0][1] == shape:
        fields = pieces[0][2]
    elif pieces:
        fields = _assemble(doc, pieces, shape)
    fields = {k: np.ascontiguousarray(v[..., 0] if v.shape[3] == 1 else v) for k, v in fields.items()}
    return fields, spacing, origin + lo * spacing


def _assemble(doc, pieces, shape):
    """Place the pieces' arrays in the whole grid; they must cover it."""
    names = list(pieces[0][2])
    if any(list(pd) != names for _, _, pd in pieces):
        raise doc.fail("its pieces hold different point fields; check the file")
    if not names:
        return {}
    # every piece's size was checked against the values it holds: the sum is not a bare header count
    if sum(int(np.prod(s, dtype=object)) for _, s, _ in pieces) < int(np.prod(shape, dtype=object)):
        raise doc.fail("its pieces do not cover the WholeExtent; check the file")
    covered = np.zeros(shape, dtype=bool)
    fields = {}
    for start, pshape, pd in pieces:
        box = tuple(slice(int(a), int(a) + b) for a, b in zip(start, pshape))
        covered[box] = True
        for k, v in pd.items():
            if k not in fields:
                fields[k] = np.zeros(shape + v.shape[3:], dtype=v.dtype)
            if fields[k].shape[3] != v.shape[3] or fields[k].dtype != v.dtype:
                raise doc.fail(f"its pieces hold field {k!r} with different components or types; check the file")
            fields[k][box] = v
    if not covered.all():
        raise doc.fail("its pieces do not cover the WholeExtent; check the file")
    return fields


# ---------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------


def _xml(name):
    return (name.replace("&", "&amp;").replace('"', "&quot;").replace("'", "&apos;")
            .replace("<", "&lt;").replace(">", "&gt;"))


def _check_name(name):
    """The field name as text; WriteError if XML cannot keep it."""
    text = str(name)
    if not text:
        raise WriteError("a field has an empty name; name every field")
    bad = [c for c in text if unicodedata.category(c) in ("Cc", "Cs") or c in "\ufffe\uffff"]
    if bad:
        raise WriteError(f"field name {text!r} contains the control character {bad[0]!r}; use printable text")
    return text


def _vtk_array(arr):
    """``arr`` in the type it is written as: bool -> UInt8, integers -> Int32 (or 64), floats -> Float64."""
    if arr.dtype == bool:
        return arr.astype(np.uint8)
    if np.issubdtype(arr.dtype, np.integer):
        if arr.size == 0:
            return arr.astype(np.int32)
        lo, hi = int(arr.min()), int(arr.max())
        for t in (np.int32, np.int64, np.uint64):
            if np.iinfo(t).min <= lo and hi <= np.iinfo(t).max:
                return arr.astype(t)  # the smallest that holds them, rather than wrap around
    if arr.dtype.kind not in "fiuO":
        return None
    try:
        return arr.astype(np.float64)
    except (TypeError, ValueError):
        return None


def grid_arrays(fields):
    """Validate voxel fields: (grid shape, dict name -> array in its written dtype)."""
    if not fields:
        raise WriteError("no fields to write; pass at least one")
    shape = None
    arrays = {}
    for name, arr in fields.items():
        arr = np.asarray(arr)
        if arr.ndim not in (3, 4) or (shape is not None and arr.shape[:3] != shape) or 0 in arr.shape:
            raise WriteError(f"field {name!r} has shape {arr.shape}; pass (n0, n1, n2) arrays on one grid")
        shape = arr.shape[:3]
        arrays[str(name)] = _vtk_array(arr)
        if arrays[str(name)] is None:
            raise WriteError(f"field {name!r} holds {arr.dtype} values; pass numbers or booleans")
    return shape, arrays


def _header(kind):
    return ('<?xml version="1.0"?>\n'
            f'<VTKFile type="{kind}" version="1.0" byte_order="LittleEndian" header_type="UInt64" '
            f'compressor="vtkZLibDataCompressor">\n')


def _write_array(fh, name, values, p, indent):
    """One zlib-compressed inline binary DataArray of flat ``values`` (p components)."""
    raw = np.ascontiguousarray(values, dtype=values.dtype.newbyteorder("<")).tobytes()
    blocks = [zlib.compress(raw[i:i + _BLOCK], _LEVEL) for i in range(0, len(raw), _BLOCK)]
    header = np.array([len(blocks), _BLOCK, len(raw) % _BLOCK] + [len(b) for b in blocks], dtype="<u8")
    # the header is encoded on its own, then the blocks in one stream, as VTK does
    blob = base64.b64encode(header.tobytes()) + base64.b64encode(b"".join(blocks))
    kind = _VTK_NAMES[values.dtype.newbyteorder("=")]
    comps = f' NumberOfComponents="{p}"' if p != 1 else ""  # VTK's default; meshio then keeps (n,) arrays
    fh.write(f'{indent}<DataArray type="{kind}" Name="{_xml(name)}"{comps} format="binary">\n'
             f'{indent}  {blob.decode("ascii")}\n{indent}</DataArray>\n')


def _point_arrays(point_data, n):
    """Named point fields as VTK-typed (n, p) arrays, each name checked."""
    arrays = {}
    for name, arr in (point_data or {}).items():
        key = _check_name(name)
        arr = np.asarray(arr)
        if arr.ndim not in (1, 2) or arr.shape[0] != n or (arr.ndim == 2 and arr.shape[1] < 1):
            raise WriteError(f"field {name!r} has shape {arr.shape}; pass (n,) or (n, p) values for {n} vertices")
        out = _vtk_array(arr)
        if out is None:
            raise WriteError(f"field {name!r} holds {arr.dtype} values; pass numbers or booleans")
        if key in arrays:
            raise WriteError(f"two fields are named {key!r}; give every field its own name")
        arrays[key] = out.reshape(n, -1)
    return arrays


def _write_cells(path, kind, V, C, arrays):
    """PolyData of triangles, or an UnstructuredGrid of triangles or tetrahedra, with point arrays."""
    n, m, width = len(V), len(C), C.shape[1]
    ind = " " * 8
    with atomic_path(path) as tmp:
        try:
            with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(_header(kind))
                if kind == "PolyData":
                    fh.write(f'  <PolyData>\n    <Piece NumberOfPoints="{n}" NumberOfVerts="0" NumberOfLines="0" '
                             f'NumberOfStrips="0" NumberOfPolys="{m}">\n      <PointData>\n')
                else:
                    fh.write(f'  <UnstructuredGrid>\n    <Piece NumberOfPoints="{n}" NumberOfCells="{m}">\n'
                             f'      <PointData>\n')
                for key, arr in arrays.items():
                    _write_array(fh, key, arr, arr.shape[1], ind)
                fh.write("      </PointData>\n      <Points>\n")
                _write_array(fh, "Points", V, 3, ind)
                fh.write("      </Points>\n      " + ("<Polys>\n" if kind == "PolyData" else "<Cells>\n"))
                _write_array(fh, "connectivity", C.astype(np.int64), 1, ind)
                _write_array(fh, "offsets", width * np.arange(1, m + 1, dtype=np.int64), 1, ind)
                if kind == "PolyData":
                    fh.write("      </Polys>\n    </Piece>\n  </PolyData>\n</VTKFile>\n")
                else:
                    _write_array(fh, "types", np.full(m, 5 if width == 3 else 10, dtype=np.uint8), 1, ind)
                    fh.write("      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n")
        except OSError as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc}); check the path") from None


def write_polydata(path, V, F, point_data=None):
    """Write a triangle mesh with named point fields as VTK PolyData (``.vtp``), atomically.

    The arrays are inline binary, zlib-compressed, with a UInt64 header: points as
    Float64, the triangles as Int64 ``connectivity``/``offsets``, booleans as UInt8,
    integers as Int32 (Int64, or UInt64, when they do not fit) and floats as Float64.
    VTK, ParaView, pyvista and :func:`read_polydata` read it.

    Parameters
    ----------
    path : str or Path
        Destination (conventionally ``.vtp``).
    V : (n, 3) or (n, 2) array_like of float
    F : (m, 3) array_like of int
    point_data : dict of str to (n,) or (n, p) numpy array, optional
        Named fields; a ``(n, p)`` field is one ``p``-component array. Names are any
        non-empty text without control characters.

    Raises
    ------
    WriteError
        A malformed mesh, a field of the wrong shape or type or with an unusable
        name, a missing folder, or a failure while writing (nothing is left behind).
    """
    from ..errors import ManifillError
    from ..validate import as_mesh

    try:
        V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    except ManifillError as exc:
        raise WriteError(f"{Path(path).name}: not written, the mesh is malformed: {exc}") from None
    _write_cells(path, "PolyData", V, F, _point_arrays(point_data, len(V)))


def write_unstructured(path, V, C, point_data=None):
    """Write triangles or tetrahedra with named point fields as a VTK UnstructuredGrid (``.vtu``), atomically.

    Encoded as :func:`write_polydata`; VTK, ParaView, pyvista and meshio read it,
    with any field name (meshio's own writer leaves ``&`` and ``<`` unescaped,
    which no XML reader accepts).

    Parameters
    ----------
    path : str or Path
        Destination (conventionally ``.vtu``).
    V : (n, 3) array_like of float
    C : (m, 3) or (m, 4) array_like of int
        Triangles or tetrahedra, validated by the caller.
    point_data : dict of str to (n,) or (n, p) numpy array, optional

    Raises
    ------
    WriteError
        As :func:`write_polydata`.
    """
    V = np.asarray(V, dtype=np.float64)
    C = np.asarray(C, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3 or C.ndim != 2 or C.shape[1] not in (3, 4):
        raise WriteError(f"{Path(path).name}: points {V.shape} and cells {C.shape}; pass (n, 3) points and "
                         f"(m, 3) triangles or (m, 4) tetrahedra")
    _write_cells(path, "UnstructuredGrid", V, C, _point_arrays(point_data, len(V)))


def write_imagedata(path, fields, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0)):
    """Write voxel fields as VTK ImageData (``.vti``), atomically.

    One point per voxel centre: ``Origin`` is the centre of voxel ``(0, 0, 0)``,
    ``Spacing`` the voxel size, every field a named point array (zlib-compressed
    inline binary, x fastest), readable by ParaView, VTK, pyvista and
    :func:`read_imagedata`.

    Parameters
    ----------
    path : str or Path
        Destination (conventionally ``.vti``).
    fields : dict of str to (n0, n1, n2) or (n0, n1, n2, p) numpy array
        Named fields on the same grid: booleans are stored as UInt8, integers as
        Int32 (Int64, or UInt64, when they do not fit), floats as Float64.
    spacing, origin : (3,) array_like of float, optional

    Raises
    ------
    WriteError
        No fields, fields of different grids, an unusable name, spacing or origin
        not three numbers, or a failure while writing (nothing is left behind).
    """
    shape, arrays = grid_arrays(fields)
    for name in arrays:
        _check_name(name)
    try:
        h = np.asarray(spacing, dtype=np.float64).reshape(3)
        o = np.asarray(origin, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise WriteError(f"spacing {spacing!r} or origin {origin!r} is not three numbers; pass e.g. "
                         f"spacing=(1.0, 1.0, 2.5)") from None
    extent = " ".join(f"0 {n - 1}" for n in shape)
    with atomic_path(path) as tmp:
        try:
            with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(_header("ImageData"))
                fh.write(f'  <ImageData WholeExtent="{extent}" Origin="{" ".join(map(repr, o.tolist()))}" '
                         f'Spacing="{" ".join(map(repr, h.tolist()))}">\n    <Piece Extent="{extent}">\n'
                         f'      <PointData>\n')
                for name, arr in arrays.items():
                    p = arr.shape[3] if arr.ndim == 4 else 1
                    # VTK orders points x fastest: Fortran order over (i, j, k), components innermost
                    flat = np.moveaxis(arr.reshape(shape + (p,)), (0, 1, 2), (2, 1, 0))
                    _write_array(fh, name, flat, p, " " * 8)
                fh.write("      </PointData>\n    </Piece>\n  </ImageData>\n</VTKFile>\n")
        except OSError as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc}); check the path") from None
