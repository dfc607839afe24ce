"""Reading VTK XML files: PolyData (``.vtp``) and UnstructuredGrid (``.vtu``) as triangles, ImageData
(``.vti``) as voxel arrays.

Every encoding VTK, ParaView and pyvista write reads (the decoder is
:class:`manifill.io.vtkxml_decode.VtkXmlDocument`), over one or several
``<Piece>`` elements; a damaged or truncated file ends in a one-line
:class:`~manifill.errors.ReadError` naming it.
"""

import numpy as np

from ..errors import ReadError
from ..tolerances import TOL
from .files import no_triangles
from .vtkxml_decode import MAX_COUNT, VtkXmlDocument, guarded

__all__ = ["read_polydata", "read_unstructured", "read_imagedata"]


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
        if values.size and (int(values.max()) > MAX_COUNT or int(values.min()) < 0):
            raise doc.fail(f"DataArray {key!r} of {tag} holds values outside 0..{MAX_COUNT} "
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
    >>> from manifill.io.vtkxml_write import write_polydata
    >>> f = os.path.join(tempfile.mkdtemp(), "t.vtp")
    >>> write_polydata(f, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], {"u": np.array([1, 2, 3])})
    >>> V, F, data = read_polydata(f)
    >>> F.tolist(), data["u"].tolist(), data["u"].dtype
    ([[0, 1, 2]], [1, 2, 3], dtype('int32'))
    """
    return guarded(lambda: _read_polydata(path), path, "VTP")


def _read_polydata(path):
    doc = VtkXmlDocument(path, "PolyData", "VTP")

    def triangles(piece, n):
        return [_fan(*_cells(doc, piece, "Polys", n)), _strips(*_cells(doc, piece, "Strips", n))]

    V, F, data = _read_pieces(doc, triangles)
    if not len(F):
        no_triangles(path, [], V, data)
    return V, F, data


def _points(doc, piece, n):
    """The ``(n, 3)`` points of one piece (2-component points get ``z = 0``)."""
    pts = piece.find("Points")
    das = [] if pts is None else pts.findall("DataArray")
    if not das:
        if n:
            raise doc.fail(f"Piece claims {n} points but has no <Points> array; the file is damaged")
        return np.zeros((0, 3))
    values, p, _ = doc.array(das[0], "Points")
    if p not in (2, 3):
        raise doc.fail(f"Points have {p} components; pass 2-D or 3-D points")
    doc.check_size(values, n, p, "the Points array")
    V = values.reshape(n, p).astype(np.float64)
    return np.column_stack([V, np.zeros(n)]) if p == 2 else V


def _read_pieces(doc, triangles):
    """``(V, F, point fields)`` of every piece, ``triangles(piece, n)`` giving each piece's triangle arrays."""
    Vs, Fs, fields, base = [], [], [], 0
    for piece in doc.body.findall("Piece"):
        n = doc.count(piece, "NumberOfPoints", 0)
        Vs.append(_points(doc, piece, n))
        fields.append((n, doc.point_data(piece, n)))
        Fs.extend(t + base for t in triangles(piece, n))
        base += n
    F = np.concatenate(Fs).astype(np.int64) if Fs else np.zeros((0, 3), np.int64)
    data = _merge(doc, fields, "point fields")
    data = {k: v[:, 0] if v.shape[1] == 1 else v for k, v in data.items()}
    return (np.concatenate(Vs) if Vs else np.zeros((0, 3))), F, data


#: VTK cell types read as surface cells: triangle, triangle strip, polygon, pixel, quad
_VTK_TRIANGLE, _VTK_STRIP, _VTK_POLYGON, _VTK_PIXEL, _VTK_QUAD = 5, 6, 7, 8, 9
#: names of the other common cell types, for the message of a file without triangles
_VTK_NAMES = {1: "vertex", 2: "poly_vertex", 3: "line", 4: "poly_line", 10: "tetra", 11: "voxel",
              12: "hexahedron", 13: "wedge", 14: "pyramid", 22: "triangle6", 24: "tetra10"}


def read_unstructured(path):
    """Read the surface cells, points and named point fields of a VTK UnstructuredGrid file (``.vtu``).

    Encodings and pieces as :func:`read_polydata`. Triangles are kept, quads, pixels and
    polygons fan-triangulated, triangle strips split; other cells (points, lines,
    solids, quadratic cells) are ignored.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    V, F, point_data
        As :func:`read_polydata`.

    Raises
    ------
    ReadError
        A missing or damaged file (the message says what is wrong in it), not an
        UnstructuredGrid, or no surface cell in it (the message lists the cell types found).

    Examples
    --------
    >>> import tempfile, os, meshio
    >>> f = os.path.join(tempfile.mkdtemp(), "t.vtu")
    >>> meshio.write_points_cells(f, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [("quad", [[0, 1, 2, 3]])])
    >>> read_unstructured(f)[1].tolist()
    [[0, 1, 2], [0, 2, 3]]
    """
    return guarded(lambda: _read_unstructured(path), path, "VTU")


def _read_unstructured(path):
    doc = VtkXmlDocument(path, "UnstructuredGrid", "VTU")
    found = set()

    def triangles(piece, n):
        starts, sizes, conn = _cells(doc, piece, "Cells", n)
        types = _cell_types(doc, piece, starts.size)
        found.update(types.tolist())
        pixel = types == _VTK_PIXEL
        if pixel.any():  # a pixel's points go in rows: (0, 1, 3, 2) is its polygon
            at = starts[pixel][:, None] + np.array([2, 3])
            conn = conn.copy()
            conn[at[:, 0]], conn[at[:, 1]] = conn[at[:, 1]], conn[at[:, 0]]
        poly = np.isin(types, (_VTK_TRIANGLE, _VTK_POLYGON, _VTK_PIXEL, _VTK_QUAD))
        strip = types == _VTK_STRIP
        return [_fan(starts[poly], sizes[poly], conn), _strips(starts[strip], sizes[strip], conn)]

    V, F, data = _read_pieces(doc, triangles)
    if not len(F):
        names = sorted(_VTK_NAMES.get(t, f"type {t}") for t in found)
        no_triangles(path, names, None if "tetra" in names else V, data)
    return V, F, data


def _cell_types(doc, piece, m):
    """The ``(m,)`` VTK cell types of a piece's ``<Cells>``."""
    elem = piece.find("Cells")
    das = {} if elem is None else {da.get("Name"): da for da in elem.findall("DataArray")}
    if m and "types" not in das:
        raise doc.fail("<Cells> has no DataArray 'types'; the file is damaged")
    if not m:
        return np.zeros(0, np.int64)
    values, _, _ = doc.array(das["types"], "Cells")
    if values.dtype.kind not in "iu" or values.size != m:
        raise doc.fail(f"DataArray 'types' of Cells holds {values.size} {values.dtype} values for {m} cells; "
                       f"check the file")
    return values.astype(np.int64)


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
    return guarded(lambda: _read_imagedata(path), path, "VTI")


def _read_imagedata(path):
    doc = VtkXmlDocument(path, "ImageData", "VTI")
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
    if np.abs(direction - np.eye(3).ravel()).max() > TOL.vti_direction:
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
