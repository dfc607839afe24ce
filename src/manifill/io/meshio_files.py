"""The files read and written through meshio (VTU reading; PLY, OFF, OBJ, STL, Gmsh), guarded against damage.

meshio's own readers loop forever or allocate for a lying count on some damaged
files (an OFF header without counts, a PLY header that never ends), and
``meshio.read`` calls ``sys.exit`` on an unparsable file: each header is checked
first, each format's reader is called directly, and every failure is one
:class:`~manifill.errors.ReadError` naming the file. Writes are atomic.
"""

import re
from pathlib import Path

import numpy as np

from ..errors import ReadError, WriteError
from .files import atomic_path, check_count, no_triangles, quiet, reading

__all__ = ["read_meshio", "write_meshio", "meshio_read"]


def read_meshio(path, fmt):
    """A surface through meshio's reader of one format, damaged files as one-line :class:`ReadError`.

    Parameters
    ----------
    path : Path
        A ``.vtu``, ``.ply``, ``.off``, ``.obj`` or ``.stl`` file.
    fmt : manifill.io.formats.Format
        Its format (for the messages).

    Returns
    -------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array
        Triangles, quads and polygons split into triangles.
    point_data : dict of str to numpy array

    Raises
    ------
    ReadError
        A damaged file, or one without triangles.
    """
    import meshio

    check = {"off": _check_off_header, "ply": _check_ply_header, "stl": _check_stl}.get(fmt.meshio)
    if check is not None:  # meshio's own errors on these are tracebacks or exits
        check(path)
    with reading(path, f"{fmt.name} mesh"):
        mesh = getattr(meshio, fmt.meshio).read(str(path))  # not meshio.read: it sys.exit()s on bad files
        faces = []
        for block in mesh.cells:
            data = np.asarray(block.data)
            if block.type == "triangle":
                faces.append(data.reshape(-1, 3))
            elif block.type == "quad":
                q = data.reshape(-1, 4)
                faces.append(np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]))
            elif block.type.startswith("polygon") and data.ndim == 2 and data.shape[1] > 4:
                faces += [data[:, [0, j, j + 1]] for j in range(1, data.shape[1] - 1)]
        if not faces:
            no_triangles(path, sorted({b.type for b in mesh.cells}), mesh.points,
                         {k: np.asarray(v) for k, v in mesh.point_data.items()})
        F = np.concatenate(faces)
        if F.dtype.kind not in "iu":
            raise ReadError(f"{path.name}: the faces are stored as {F.dtype}, not integers; check the file")
        V = np.asarray(mesh.points, dtype=np.float64)
        point_data = {k: np.asarray(v) for k, v in mesh.point_data.items()}
    return V, F.astype(np.int64), point_data


def _check_off_header(path):
    """Reject an OFF file without its counts line, or with counts the file cannot hold."""
    words = []
    try:
        with open(path, "rb") as fh:
            for raw in fh:
                line = raw.split(b"#")[0].strip()
                if line:
                    words.extend(line.split())
                if len(words) >= 4:
                    break
    except OSError as exc:
        raise ReadError(f"{path.name}: could not read ({exc})") from None
    counts = None
    if len(words) >= 4 and words[0].endswith(b"OFF"):
        try:
            counts = [int(w) for w in words[1:4]]
        except ValueError:
            counts = None
    if counts is None:
        raise ReadError(f"{path.name}: not a readable OFF mesh (no 'OFF' line followed by vertex, face "
                        f"and edge counts); check the file")
    check_count(counts[0], path, "vertices", bytes_each=6)
    check_count(counts[1], path, "faces", bytes_each=8)


#: bytes of one PLY property value in a binary file
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
              "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "int64": 8, "uint64": 8,
              "double": 8, "float64": 8}
_PLY_END = re.compile(rb"^[ \t\r\v\f]*end_header[ \t\r\v\f]*$", re.M)


def _check_ply_header(path):
    """Reject a PLY file whose header never ends (meshio would wait for it forever) or whose counts lie."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
    except OSError as exc:
        raise ReadError(f"{path.name}: could not read ({exc})") from None
    end = _PLY_END.search(head)
    if end is None:
        raise ReadError(f"{path.name}: not a readable PLY mesh (no 'end_header' line closes its header); the file "
                        f"is truncated or damaged, check it")
    lines = [line.split() for line in head[:end.start()].decode("latin-1").splitlines()]
    fmt = next((w for w in lines[1:] if w and w[0] != "comment"), None)  # the line after 'ply'
    if fmt is None or fmt[:1] != ["format"] or fmt[1:] not in (["ascii", "1.0"], ["binary_little_endian", "1.0"],
                                      ["binary_big_endian", "1.0"]):
        said = "nothing" if fmt is None else f"the line {' '.join(fmt)[:60]!r}"
        raise ReadError(f"{path.name}: not a readable PLY mesh ({said} after 'ply', where 'format ascii 1.0' "
                        f"or 'format binary_little_endian 1.0' belongs); the file is damaged, check it")
    binary = any(w[:1] == ["format"] and len(w) > 1 and w[1].startswith("binary") for w in lines)
    elements = []  # [name, count, fewest bytes of one]
    for w in lines:
        if w[:1] == ["element"] and len(w) >= 3:
            if not re.fullmatch(r"[0-9]{1,30}", w[2]):
                raise ReadError(f"{path.name}: the header line 'element {w[1]} {w[2][:40]}' gives no count; the "
                                f"file is damaged, check it")
            elements.append([w[1], int(w[2]), 0])
        elif w[:1] == ["property"] and elements:
            kind = w[2] if len(w) > 2 and w[1] == "list" else (w[1] if len(w) > 1 else "")
            elements[-1][2] += _PLY_SIZES.get(kind, 1) if binary else 2
    for name, n, each in elements:
        check_count(n, path, f"'{name}' elements", bytes_each=max(each, 1), start=end.end() + 1)


def _check_stl(path):
    """Say what is wrong with an STL file that is neither binary of the size its count gives nor ASCII text.

    meshio reads a file as binary when ``84 + 50 * count`` bytes match its size, as ASCII otherwise (its first
    line skipped, whatever it says): each line of an ASCII file is checked here, with its number in the message.
    """
    try:
        size = path.stat().st_size
        with open(path, "rb") as fh:
            head = fh.read(84)
            if size >= 84 and 84 + 50 * int.from_bytes(head[80:84], "little") == size:
                return  # binary, its count matching its size
            start = (head + fh.read(1024)).removeprefix(b"\xef\xbb\xbf")  # a text editor's byte-order mark
            if not (start.lstrip()[:5].lower() == b"solid" or start.isascii() and b"facet" in start):
                count = int.from_bytes(head[80:84], "little") if size >= 84 else None
                said = "" if count is None else (f": its header gives {count} triangles, {84 + 50 * count} bytes, "
                                                  f"and the file has {size}")
                raise ReadError(f"{path.name}: not a readable STL mesh (neither ASCII, which starts with "
                                f"'solid', nor binary{said}); the file is truncated or damaged, check it")
            fh.seek(0)
            _check_ascii_stl(fh, path.name)
    except OSError as exc:
        raise ReadError(f"{path.name}: could not read ({exc})") from None


def _check_ascii_stl(fh, name):
    """Each line of an ASCII STL, and each facet's three vertices, checked (the message names the line)."""
    facet, corners, inside = None, 3, False  # the line of the current facet, its vertices, not yet ended
    for number, line in enumerate(fh, 1):
        problem = _stl_line_problem(line, number == 1)
        word = line.split()[:1]
        if not problem and word in ([b"facet"], [b"endsolid"]):
            if corners != 3:
                problem = f"{word[0].decode()!r} after {corners} vertices of " + \
                    (f"the facet of line {facet}; 3 belong" if facet else "no facet")
            facet, corners = (number, 0) if word == [b"facet"] else (None, 3)
        corners += word == [b"vertex"]
        inside = (inside or word == [b"facet"]) and word != [b"endfacet"]
        if problem:
            raise ReadError(f"{name}: not a readable STL mesh (an ASCII STL, 'solid' first, whose line {number} "
                            f"holds {problem}); the file is damaged, check it")
    if inside:
        raise ReadError(f"{name}: not a readable STL mesh (an ASCII STL that ends inside the facet of line "
                        f"{facet}, after {corners} of its vertices); the file is truncated, check it")


_STL_WORDS = {b"solid", b"endsolid", b"outer", b"endloop", b"endfacet"}


def _stl_line_problem(line, first):
    """What is wrong with one line of an ASCII STL, or None (the first line names the solid: anything goes)."""
    if first:
        return None
    try:
        line.decode("ascii")
    except UnicodeDecodeError:
        return "bytes that are not text"
    w = line.split()
    if not w or w[0] in _STL_WORDS:
        return None
    numbers = w[1:] if w[0] == b"vertex" else (w[2:] if w[:2] == [b"facet", b"normal"] else None)
    if numbers is None:
        return f"{w[0].decode()[:20]!r}, not an STL keyword"
    if len(numbers) != 3:
        return f"{len(numbers)} numbers where 3 belong"
    for x in numbers:
        try:
            float(x)
        except ValueError:
            return f"{x.decode()[:20]!r}, not a number"
    return None


def write_meshio(path, V, cells, point_data, fmt):
    """Write cells and point fields through meshio's writer of format ``fmt``, atomically.

    Parameters
    ----------
    path : str or Path
    V : (n, 3) array_like of float
    cells : list of (str, (m, k) numpy array)
        meshio's cell blocks, e.g. ``[("triangle", F)]``.
    point_data : dict of str to numpy array
    fmt : str
        meshio's format name (``"ply"``, ``"gmsh22"``).

    Raises
    ------
    WriteError
        meshio fails (nothing is left behind).
    """
    import meshio

    mesh = meshio.Mesh(np.asarray(V, dtype=np.float64), cells, point_data=point_data)
    with atomic_path(path) as tmp:
        try:
            with quiet():  # meshio prints its notes (e.g. Gmsh's "Appending zeros") itself
                meshio.write(tmp, mesh, file_format=fmt)
        except (meshio.WriteError, ValueError, KeyError, TypeError, OSError) as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc}); check the path and the fields") from None


def meshio_read(path, ext, fmt):
    """meshio's reader of one format, with a damaged file as one-line :class:`ReadError`.

    Parameters
    ----------
    path : Path
    ext : str
        The extension (for the message).
    fmt : str
        meshio's reader module (``"gmsh"``, ``"vtu"``).

    Returns
    -------
    meshio.Mesh
    """
    import meshio

    with reading(path, f"{ext[1:].upper()} mesh"):
        return getattr(meshio, fmt).read(str(path))  # not meshio.read: it sys.exit()s on bad files
