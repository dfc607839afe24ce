"""Reading legacy VTK files (``.vtk``): POLYDATA and UNSTRUCTURED_GRID meshes with their point data.

:func:`read_legacy` reads file versions 2.0 to 5.1, ASCII or BINARY (big-endian, as
the format defines it), with cells in the classic ``POLYGONS n size`` / ``CELLS n
size`` layout or the 5.x ``OFFSETS`` / ``CONNECTIVITY`` one. Polygons, quads and
triangle strips become triangles, tetrahedra are kept, other cells are skipped. Every
point attribute (``SCALARS``, ``VECTORS``, ``NORMALS``, ``TEXTURE_COORDINATES``,
``COLOR_SCALARS``, ``TENSORS``, ``FIELD`` arrays...) is returned under its decoded name
with its stored type; cell data, lookup tables, string arrays and ``METADATA`` blocks
are read past. No count in a file is trusted: each is checked against the bytes that
follow before anything is allocated, and every malformed file ends in a one-line
:class:`~manifill.errors.ReadError` naming it.

The lines, counts and arrays are read by :class:`manifill.io.vtklegacy_scan.LegacyScanner`;
the writer is :func:`manifill.io.vtklegacy_write.write_legacy`.
"""

import re
from pathlib import Path

import numpy as np

from ..errors import ReadError
from .vtklegacy_scan import LegacyScanner, decode_name, quoted, quoted_line

__all__ = ["read_legacy"]

#: point attribute keyword -> number of components (None: given on the line)
_ATTRIBUTES = {b"scalars": None, b"vectors": 3, b"normals": 3, b"tensors": 9, b"tensors6": 6,
               b"texture_coordinates": None, b"color_scalars": None, b"global_ids": 1, b"pedigree_ids": 1,
               b"edge_flags": 1}
_GEOMETRY = {"POLYDATA": (b"vertices", b"lines", b"polygons", b"triangle_strips"),
             "UNSTRUCTURED_GRID": (b"cells", b"cell_types")}
_NOT_MESHES = ("STRUCTURED_POINTS", "STRUCTURED_GRID", "RECTILINEAR_GRID", "FIELD")
#: VTK cell type -> how it becomes triangles (unstructured grids)
_UG_TRIANGLE, _UG_STRIP, _UG_POLYGON, _UG_QUAD, _UG_TETRA = 5, 6, 7, 9, 10


def read_legacy(path):
    """Read a legacy VTK POLYDATA or UNSTRUCTURED_GRID mesh with its point data.

    Parameters
    ----------
    path : str or Path
        A ``.vtk`` file, version 2.0 to 5.1, ASCII or BINARY.

    Returns
    -------
    V : (n, 3) float64 numpy array
        The points.
    cells : dict
        ``"triangle"``: (m, 3) int64 numpy array (triangles, quads and polygons
        fan-split, triangle strips with alternating orientation) and
        ``"tetra"``: (k, 4) int64 numpy array, each present only when the file
        has such cells (unstructured grids: types 5 triangle, 6 strip, 7 polygon,
        9 quad, 10 tetra). Vertices, lines and other cell types are skipped.
    point_data : dict of str to (n,) or (n, p) numpy array
        Every point array under its name (``%XX`` escapes decoded), of the type
        stored in the file (``long`` read as 8 bytes; ``vtkIdType``, stored in 4,
        returned as int64; ``COLOR_SCALARS`` as uint8; all as VTK does).

    Raises
    ------
    ReadError
        A missing file, a dataset that is not a mesh (``STRUCTURED_POINTS``...),
        an unsupported data type (``bit``), or a malformed file: a bad or lying
        count, a truncated section, a cell index outside the points, a point
        array of the wrong length. The message is one line naming the file.
    """
    path = Path(path)
    if not path.is_file():
        raise ReadError(f"{path}: no such file" if not path.exists() else f"{path}: not a file; pass a file")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ReadError(f"{path.name}: could not read ({exc.strerror or exc}); check the file's permissions") from None
    try:
        return _Reader(path.name, data).read()
    except ReadError:
        raise
    except (MemoryError, OverflowError, IndexError, ValueError) as exc:  # a safety net for what the checks miss
        raise ReadError(f"{path.name}: not a readable legacy VTK file ({type(exc).__name__}); check or re-export "
                        f"the file") from None


class _Reader(LegacyScanner):
    """The sections of one legacy VTK mesh file, read on a :class:`LegacyScanner`."""

    # -- sections -----------------------------------------------------------

    def header(self):
        """Read the four header lines; returns the dataset kind (``"POLYDATA"`` or ``"UNSTRUCTURED_GRID"``)."""
        first = self.raw_line()
        if first is None:
            self.fail("the file is empty", "pass a legacy VTK file")
        if not first.startswith(b"# vtk DataFile Version"):
            self.fail("not a legacy VTK file (line 1 is not '# vtk DataFile Version x.y')", "pass a .vtk file")
        m = re.match(rb"\s*([0-9]{1,4})\.([0-9]{1,4})", first[22:])
        if not m:
            self.fail(f"line 1 {quoted_line([first])} gives no file version x.y")
        major, minor = int(m.group(1)), int(m.group(2))
        if not 2 <= major <= 5:
            self.fail(f"file version {major}.{minor} is not one this reader knows (2.0 to 5.1)",
                      "re-export it as version 4.2 or 5.1")
        if self.raw_line() is None:
            self.fail("the file ends after its first line", "the file is truncated; re-export it")
        words = self.line()
        mode = words[0].lower() if words else b""
        if not (mode.startswith(b"ascii") or mode.startswith(b"binary")):
            self.fail(f"line 3 is {quoted_line(words or [b''])}, not ASCII or BINARY")
        self.binary = mode.startswith(b"binary")
        words = self.line()
        if not words or words[0].lower() != b"dataset" or len(words) < 2:
            self.fail(f"the line after ASCII/BINARY is {quoted_line(words or [b''])}, not 'DATASET type'")
        kind = words[1].decode("latin-1").upper()
        if kind not in _GEOMETRY:
            if kind in _NOT_MESHES:
                self.fail(f"DATASET {kind} is not a mesh; pass POLYDATA or UNSTRUCTURED_GRID",
                          "extract its surface (e.g. pyvista's extract_surface) and save that")
            self.fail(f"DATASET {quoted(words[1])} is not a legacy VTK dataset type")
        return kind

    def read(self):
        """The whole file as (V, cells, point_data)."""
        kind = self.header()
        geometry = _GEOMETRY[kind]
        points = types = None
        cells = {}
        point_data = {}
        pd_count = None
        section, count = None, None  # the data section being read: b"point_data" or b"cell_data"
        while (words := self.line()) is not None:
            kw = words[0].lower()
            if kw in (b"metadata", b"information"):
                self.skip_metadata()
            elif kw in (b"point_data", b"cell_data"):
                count = self.count(words, 1, "count")
                section = kw
                if kw == b"point_data":
                    if pd_count is not None:
                        self.fail("the file has two POINT_DATA sections")
                    pd_count = count
            elif section is not None:
                if kw not in _ATTRIBUTES and kw not in (b"field", b"lookup_table"):
                    self.fail(f"unknown {section.decode().upper()} entry {quoted_line(words)}")
                for name, arr in self.attribute(words, count, section[:-5].decode() + "s"):
                    if section == b"point_data" and arr is not None:
                        point_data[name] = arr
            elif kw == b"field":  # the dataset's own field data: arrays of any length, not per point
                self.field(words, None, "")
            elif kw == b"points":
                if points is not None:
                    self.fail("the file has two POINTS sections")
                n = self.count(words, 1, "point count")
                if len(words) < 3:
                    self.fail(f"the {quoted_line(words)} line lacks its data type")
                arr = self.array(words[2], n, 3, f"{n:,} points")
                if arr is None:
                    self.fail("POINTS are strings")
                points = np.asarray(arr, dtype=np.float64).reshape(n, 3)
            elif kw in geometry:
                if kw in cells or (kw == b"cell_types" and types is not None):
                    self.fail(f"the file has two {kw.decode().upper()} sections")
                if kw == b"cell_types":
                    n = self.count(words, 1, "cell count")
                    types = self.values(np.dtype("i4"), n, f"{n:,} cell types")
                else:
                    cells[kw] = self.cells(words)
            else:
                self.fail(f"unknown {kind} section {quoted_line(words)}")
        if points is None:
            self.fail("the file has no POINTS section", "the file is truncated or not a mesh; re-export it")
        n = len(points)
        if pd_count is not None and pd_count != n:
            self.fail(f"POINT_DATA has {pd_count:,} values per array for {n:,} points")
        for kw, (_, conn) in cells.items():
            if conn.size and (conn.min() < 0 or conn.max() >= n):
                bad = conn[(conn < 0) | (conn >= n)][0]
                self.fail(f"{kw.decode().upper()} uses point {bad} but there are {n:,} points (0..{n - 1})")
        if kind == "POLYDATA":
            tris = [split(*cells[kw]) for kw, split in ((b"polygons", _fan), (b"triangle_strips", _strip))
                    if kw in cells]
            out = {"triangle": np.concatenate(tris)} if tris else {}
        else:
            out = self.unstructured(cells.get(b"cells"), types)
        return points, {k: v for k, v in out.items() if len(v)}, point_data

    def cells(self, words):
        """A cell section (``POLYGONS``, ``CELLS``...) as (offsets, connectivity), both int64."""
        what = words[0].decode("latin-1").upper()
        first = self.count(words, 1, "cell count")
        size = self.count(words, 2, "size")
        if self.at(b"offsets"):  # 5.x: offsets (cells + 1) and connectivity arrays
            nxt = self.line()
            if len(nxt) < 2:
                self.fail(f"{what}'s OFFSETS line lacks its data type")
            offsets = self.int_array(nxt[1], first, f"{what} {first:,} offsets")
            words = self.line()
            if not words or words[0].lower() != b"connectivity" or len(words) < 2:
                self.fail(f"{what} OFFSETS are followed by {quoted_line(words or [b''])}, not 'CONNECTIVITY type'")
            conn = self.int_array(words[1], size, f"{what} connectivity of {size:,} indices")
            if first == 0:
                offsets = np.zeros(1, dtype=np.int64)
            if offsets[0] != 0 or offsets[-1] != size or (np.diff(offsets) < 0).any():
                self.fail(f"{what} offsets do not run from 0 up to the {size:,} indices of the connectivity")
            return offsets, conn
        if first > size:
            self.fail(f"{what} claims {first:,} cells in {size:,} values (each cell takes at least one)")
        records = self.values(np.dtype("i4"), size, f"{what} {first:,} cells in {size:,} values")
        return self.unpack(records.astype(np.int64), first, what)

    def unpack(self, records, n, what):
        """Classic cell records ``k i1 .. ik`` as (offsets, connectivity)."""
        size = len(records)
        if n == 0:
            if size:
                self.fail(f"{what} claims no cells but {size:,} values")
            return np.zeros(1, dtype=np.int64), records
        k = int(records[0])
        if k >= 0 and n * (k + 1) == size and (records[::k + 1] == k).all():  # all cells alike
            return np.arange(n + 1, dtype=np.int64) * k, records.reshape(n, k + 1)[:, 1:].ravel()
        starts = np.empty(n, dtype=np.int64)
        values, p = records.tolist(), 0
        for i in range(n):
            if p >= size:
                self.fail(f"{what}: its values end after {i:,} of the {n:,} cells the header claims")
            if values[p] < 0:
                self.fail(f"{what}: cell {i} claims {values[p]} points")
            starts[i] = p
            p += values[p] + 1
        if p != size:
            self.fail(f"{what}: the {n:,} cells take {p:,} values, not the {size:,} the header claims")
        sizes = records[starts]
        return np.concatenate([[0], np.cumsum(sizes)]), np.delete(records, starts)

    def unstructured(self, cells, types):
        """Triangles (types 5, 6, 7, 9) and tetrahedra (type 10) of CELLS and CELL_TYPES; other types skipped."""
        if cells is None and types is None:
            return {}
        if cells is None or types is None:
            self.fail("the file has " + ("CELL_TYPES but no CELLS" if cells is None else "CELLS but no CELL_TYPES"))
        offsets, conn = cells
        n = len(offsets) - 1
        if len(types) != n:
            self.fail(f"CELL_TYPES gives {len(types):,} types for {n:,} cells")
        sizes = np.diff(offsets)
        for t, k, label in ((_UG_TRIANGLE, 3, "triangle"), (_UG_QUAD, 4, "quad"), (_UG_TETRA, 4, "tetra")):
            wrong = (types == t) & (sizes != k)
            if wrong.any():
                i = int(np.flatnonzero(wrong)[0])
                self.fail(f"cell {i} is a {label} (type {t}) with {sizes[i]} points instead of {k}")
        fan = np.isin(types, (_UG_TRIANGLE, _UG_POLYGON, _UG_QUAD))
        strip = types == _UG_STRIP
        tris, owner = [], []
        for pick, split in ((fan, _fan), (strip, _strip)):
            ids = np.flatnonzero(pick)
            sub = np.concatenate([[0], np.cumsum(sizes[ids])])
            idx = _ranges(offsets[ids], sizes[ids])
            t, which = split(sub, conn[idx], with_owner=True)
            tris.append(t)
            owner.append(ids[which])
        order = np.argsort(np.concatenate(owner), kind="stable")  # the file's cell order
        tets = offsets[:-1][types == _UG_TETRA]
        return {"triangle": np.concatenate(tris)[order], "tetra": conn[tets[:, None] + np.arange(4)].reshape(-1, 4)}

    def attribute(self, words, n, items):
        """One entry of a POINT_DATA or CELL_DATA section (``n`` ``items``) as (name, array or None) pairs."""
        kw = words[0].lower()
        if kw == b"field":
            return self.field(words, n, items)
        if kw == b"lookup_table":
            size = self.count(words, 2, "table size")
            if self.binary:
                self.values(np.dtype("u1"), 4 * size, f"LOOKUP_TABLE of {size:,} colours")
            else:
                self.values(np.dtype("f4"), 4 * size, f"LOOKUP_TABLE of {size:,} colours")
            return []
        if len(words) < 3:
            self.fail(f"the {quoted_line(words)} line lacks its name or type")
        name = decode_name(words[1])
        what = f"{kw.decode().upper()} {name!r}"
        comps = _ATTRIBUTES[kw]
        if kw == b"color_scalars":
            comps = self.count(words, 2, "component count", least=1)
            if self.binary:
                return [(name, self.array(b"unsigned_char", n, comps, what))]
            arr = self.array(b"float", n, comps, what)  # VTK scales ASCII colours in 0..1 to bytes
            return [(name, np.clip(np.nan_to_num(255.0 * arr.astype(np.float64) + 0.5), 0, 255).astype(np.uint8))]
        if kw == b"texture_coordinates":
            comps = self.count(words, 2, "dimension", least=1)
            if comps > 3:
                self.fail(f"{what} has dimension {comps}, not 1, 2 or 3")
            vtype = words[3] if len(words) > 3 else self.fail(f"the {quoted_line(words)} line lacks its type")
        else:
            vtype = words[2]
        if kw == b"scalars":
            comps = self.count(words, 3, "component count", least=1) if len(words) > 3 else 1
            if self.at(b"lookup_table"):
                self.line()
        return [(name, self.array(vtype, n, comps, what))]

    def field(self, words, n, items):
        """A FIELD block: ``n`` tuples (``items``) per array; None: any, for the dataset's own field data."""
        k = self.count(words, 2, "array count")
        out = []
        for _ in range(k):
            head = self.line()
            while head and head[0].lower() == b"metadata":
                self.skip_metadata()
                head = self.line()
            if head is None:
                self.fail(f"FIELD claims {k:,} arrays but the file ends after {len(out):,}",
                          "the file is truncated; re-export it")
            if head[0] == b"NULL_ARRAY":
                continue
            name = decode_name(head[0])
            comps = self.count(head, 1, "component count", least=1)
            tuples = self.count(head, 2, "tuple count")
            if n is not None and tuples != n:
                self.fail(f"FIELD array {name!r} has {tuples:,} tuples for {n:,} {items}")
            if len(head) < 4:
                self.fail(f"the {quoted_line(head)} line lacks its data type")
            out.append((name, self.array(head[3], tuples, comps, f"FIELD array {name!r}")))
        return out


def _fan(offsets, conn, with_owner=False):
    """Fan triangles ``(p0, pi, pi+1)`` of cells given by offsets into ``conn``."""
    starts, sizes = offsets[:-1], np.diff(offsets)
    t = np.maximum(sizes - 2, 0)
    cell = np.repeat(np.arange(len(t)), t)
    local = np.arange(int(t.sum())) - np.repeat(np.cumsum(t) - t, t)
    s = starts[cell]
    tris = np.stack([conn[s], conn[s + local + 1], conn[s + local + 2]], axis=1).astype(np.int64).reshape(-1, 3)
    return (tris, cell) if with_owner else tris


def _strip(offsets, conn, with_owner=False):
    """Triangles of triangle strips, every second one flipped to keep the orientation."""
    starts, sizes = offsets[:-1], np.diff(offsets)
    t = np.maximum(sizes - 2, 0)
    cell = np.repeat(np.arange(len(t)), t)
    local = np.arange(int(t.sum())) - np.repeat(np.cumsum(t) - t, t)
    s = starts[cell] + local
    odd = local % 2 == 1
    a, b = np.where(odd, conn[s + 1], conn[s]), np.where(odd, conn[s], conn[s + 1])
    tris = np.stack([a, b, conn[s + 2]], axis=1).astype(np.int64).reshape(-1, 3)
    return (tris, cell) if with_owner else tris


def _ranges(starts, sizes):
    """The indices ``starts[i] .. starts[i] + sizes[i] - 1`` of all i, concatenated."""
    total = int(sizes.sum())
    return np.arange(total) - np.repeat(np.cumsum(sizes) - sizes - starts, sizes)
